"""The outcome of one sandboxed attempt, and the host side of the harness's report.

Everything the report says comes from inside the sandbox, where the LLM-written script could
have rewritten it: it is size-capped, type-checked and its file names are vetted before the
host writes a single byte. A malformed report is a failed attempt, never a host crash.
"""

from __future__ import annotations

import base64
import binascii
import json
import os
import stat
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path, PurePosixPath

MAX_MESSAGE_CHARS = 4000
MAX_TRACEBACK_CHARS = 16000
MAX_NAME_CHARS = 200
MAX_DEPTH = 4


@dataclass
class ExecResult:
    """What happened when a script ran in the sandbox (a value, also when the script failed)."""

    exit_code: int | None
    stdout: str
    stderr: str
    timed_out: bool
    duration_s: float
    script_duration_s: float | None = None
    error_type: str | None = None
    error_message: str | None = None
    traceback: str | None = None
    files: list[Path] = field(default_factory=list)
    backend: str = ""

    @property
    def ok(self) -> bool:
        """The script ran to the end of ``generate`` without raising, within its limits."""
        return self.exit_code == 0 and not self.timed_out and self.error_type is None

    def to_dict(self) -> dict:
        """A JSON-ready copy (for traces and run folders), with ``ok`` included."""
        data = asdict(self)
        data["files"] = [str(path) for path in self.files]
        data["ok"] = self.ok
        return data

    @property
    def overhead_s(self) -> float | None:
        """Wall time the sandbox added on top of the script's own time."""
        if self.script_duration_s is None:
            return None
        return self.duration_s - self.script_duration_s


@dataclass
class Report:
    """The harness's report after vetting."""

    error_type: str | None = None
    error_message: str | None = None
    traceback: str | None = None
    script_duration_s: float | None = None
    files: dict[str, bytes] = field(default_factory=dict)


class ReportInvalid(ValueError):
    """The harness report is missing or malformed (the script tampered with it or died)."""


def read_report(path: Path, max_bytes: int, max_files: int, wall_time_s: float) -> Report:
    """Parse and vet the report at ``path``; raise :class:`ReportInvalid` if unusable."""
    try:
        info = os.lstat(path)
    except OSError as err:
        raise ReportInvalid("no report") from err
    if not stat.S_ISREG(info.st_mode) or info.st_size == 0:
        raise ReportInvalid("no report")
    if info.st_size > max_bytes * 4 // 3 + 1_000_000:
        raise ReportInvalid(f"report of {info.st_size} bytes exceeds the output limit")
    try:
        with open(path, "rb") as handle:
            raw = json.loads(handle.read(info.st_size))
    except (ValueError, RecursionError) as err:
        raise ReportInvalid(f"report is not JSON: {type(err).__name__}") from err
    if not isinstance(raw, dict):
        raise ReportInvalid("report is not an object")
    return Report(
        error_type=_text(raw.get("error_type"), MAX_NAME_CHARS),
        error_message=_text(raw.get("error_message"), MAX_MESSAGE_CHARS),
        traceback=_text(raw.get("traceback"), MAX_TRACEBACK_CHARS, keep_tail=True),
        script_duration_s=_duration(raw.get("script_duration_s"), wall_time_s),
        files=_files(raw.get("files"), max_bytes, max_files),
    )


def _text(value: object, limit: int, keep_tail: bool = False) -> str | None:
    if value is None:
        return None
    text = value if isinstance(value, str) else repr(value)[:limit]
    if len(text) <= limit:
        return text
    return text[-limit:] if keep_tail else text[:limit]


def _duration(value: object, wall_time_s: float) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float) or value != value:
        return None
    return min(max(float(value), 0.0), wall_time_s)


def _files(value: object, max_bytes: int, max_files: int) -> dict[str, bytes]:
    if value is None:
        return {}
    if not isinstance(value, list) or len(value) > max_files:
        raise ReportInvalid(f"report lists more than {max_files} files or no list")
    files: dict[str, bytes] = {}
    total = 0
    for item in value:
        if not isinstance(item, dict) or not isinstance(item.get("data"), str):
            raise ReportInvalid("report has a malformed file entry")
        name = safe_relative_name(item.get("name"))
        try:
            data = base64.b64decode(item["data"], validate=True)
        except (binascii.Error, ValueError) as err:
            raise ReportInvalid(f"file {name!r} is not base64") from err
        total += len(data)
        if total > max_bytes:
            raise ReportInvalid(f"files exceed the output limit of {max_bytes} bytes")
        files[name] = data
    return files


def safe_relative_name(name: object) -> str:
    """``name`` if it is a plain relative path inside the output folder, else ReportInvalid."""
    if not isinstance(name, str) or not name or len(name) > MAX_NAME_CHARS or "\0" in name:
        raise ReportInvalid(f"unsafe file name {name!r}")
    parts = PurePosixPath(name).parts
    if (name.startswith("/") or not parts or len(parts) > MAX_DEPTH
            or any(part in (".", "..") for part in parts) or "\\" in name):
        raise ReportInvalid(f"unsafe file name {name!r}")
    return "/".join(parts)


def write_files(files: dict[str, bytes], out_dir: Path) -> list[Path]:
    """Write vetted files into ``out_dir`` atomically, never through a link; return the paths."""
    written = []
    for name, data in files.items():
        target = out_dir / name
        _make_real_dirs(out_dir, target.parent)
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".sandbox-")
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.replace(tmp, target)  # replaces a link of that name, never writes through it
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        written.append(target)
    return written


def _make_real_dirs(root: Path, folder: Path) -> None:
    current = root
    for part in folder.relative_to(root).parts:
        current = current / part
        try:
            mode = os.lstat(current).st_mode
        except FileNotFoundError:
            current.mkdir()
            continue
        if not stat.S_ISDIR(mode):
            raise ReportInvalid(f"output path {current} exists and is not a folder")

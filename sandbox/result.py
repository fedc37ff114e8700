"""The outcome of one sandboxed attempt, and the host side of the harness's report.

Everything the report says comes from inside the sandbox, where the LLM-written script could
have rewritten it: it is size-capped, type-checked and its file names are vetted before the
host writes a single byte. An output the host refuses (its name, or beyond a limit) is dropped
with a warning and the others still count; a malformed report is a failed attempt, never a
host crash.
"""

from __future__ import annotations

import base64
import binascii
import fnmatch
import json
import math
import os
import re
import stat
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

from scenweave.errors import ScenarioError
from scenweave.files import write_bytes_atomic

MAX_MESSAGE_CHARS = 4000
MAX_TRACEBACK_CHARS = 16000
MAX_TYPE_CHARS = 200
#: the longest output name the host takes
MAX_NAME_CHARS = 100
#: the characters of an output name the host takes (and no leading '-' or '.')
SAFE_NAME = re.compile(r"[A-Za-z0-9_.-]+")
#: dropped outputs named one by one in ``ExecResult.warnings``; the rest are counted
MAX_WARNINGS = 20
#: the moments the harness reports (wall clock): job begun, imports done, generate() returned,
#: outputs collected
MARKS = ("begun", "imported", "generated", "collected")


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
    warnings: list[str] = field(default_factory=list)
    #: where the wall time went: start, import, generate, collect, stop (seconds)
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """The script ran to the end of ``generate`` without raising, within its limits."""
        return self.exit_code == 0 and not self.timed_out and self.error_type is None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready copy (for traces and run folders), with ``ok`` included."""
        data = asdict(self)
        data["files"] = [str(path) for path in self.files]
        data["ok"] = self.ok
        return data


@dataclass
class Report:
    """The harness's report after vetting."""

    error_type: str | None = None
    error_message: str | None = None
    traceback: str | None = None
    script_duration_s: float | None = None
    files: dict[str, bytes] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    marks: dict[str, float] = field(default_factory=dict)


class ReportInvalid(ScenarioError, ValueError):
    """The harness report is missing or malformed (the script tampered with it or died)."""


def read_report(path: Path, max_bytes: int, max_files: int, wall_time_s: float,
                allowed: Sequence[str]) -> Report:
    """Parse and vet the report at ``path``; raise :class:`ReportInvalid` if unusable.

    Outputs whose name is not in ``allowed`` (or not plain, see :func:`name_problem`), or
    beyond the limits, are dropped one by one with a warning; the rest still count.
    """
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
    files, warnings = _files(raw.get("files"), max_bytes, max_files, allowed)
    return Report(
        error_type=_text(raw.get("error_type"), MAX_TYPE_CHARS),
        error_message=_text(raw.get("error_message"), MAX_MESSAGE_CHARS),
        traceback=_text(raw.get("traceback"), MAX_TRACEBACK_CHARS, keep_tail=True),
        script_duration_s=_duration(raw.get("script_duration_s"), wall_time_s),
        files=files, warnings=warnings, marks=_marks(raw.get("marks")),
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


def phase_timings(began_at: float, marks: dict[str, float], ended_at: float,
                  host_collect_s: float) -> dict[str, float]:
    """Where an attempt's wall time went (seconds): ``start`` (until the job began inside),
    ``import`` (the script's module body: its imports, e.g. scenariogeneration's, which a warm
    sandbox has done), ``generate``, ``collect`` (inside and on the host), ``stop`` (report,
    exit, teardown). The harness's marks are untrusted: they are clamped into the host's span."""
    if any(key not in marks for key in MARKS):
        return {}
    moments, low = [], began_at
    for moment in (began_at, *(marks[key] for key in MARKS), ended_at):
        low = min(max(moment, low), ended_at)
        moments.append(low)
    start, imports, generate, collect, stop = (b - a for a, b in pairwise(moments))
    return {"start": start, "import": imports, "generate": generate,
            "collect": collect + host_collect_s, "stop": stop}


def _marks(value: object) -> dict[str, float]:
    if not isinstance(value, dict):
        return {}
    return {key: float(value[key]) for key in MARKS
            if isinstance(value.get(key), int | float) and not isinstance(value[key], bool)
            and math.isfinite(value[key])}


def name_problem(name: object, allowed: Sequence[str]) -> str | None:
    """Why the host refuses an output called ``name``, or None when it takes it.

    Taken: a plain file name (no folder) of ASCII letters, digits, ``_``, ``.`` and ``-``, not
    starting with ``-`` or ``.``, at most ``MAX_NAME_CHARS`` long, matching one of the
    ``allowed`` patterns (``SandboxSettings.output_names``).
    """
    if not isinstance(name, str):
        return "the name is not text"
    if len(name) > MAX_NAME_CHARS:
        return f"longer than {MAX_NAME_CHARS} characters"
    if "/" in name or "\\" in name:
        return "a path, not a plain file name (outputs go straight into the output folder)"
    if name.startswith(("-", ".")):
        return "starts with '-' or '.'"
    if not SAFE_NAME.fullmatch(name):
        return "not only ASCII letters, digits, '_', '.' and '-'"
    if not any(fnmatch.fnmatchcase(name, pattern) for pattern in allowed):
        return f"not one of SandboxSettings.output_names ({', '.join(allowed)})"
    return None


def shown(name: object) -> str:
    """``name`` safe to print in a log line: ASCII-escaped, quoted and cut short."""
    if not isinstance(name, str):
        return f"<{type(name).__name__}>"
    text = ascii(name)
    return text if len(text) <= 80 else f"{text[:60]}...' ({len(name)} characters)"


class _Intake:
    """A report's outputs taken one by one: each refused one is dropped and the reason kept,
    so one bad entry never costs the others (the scenario file above all)."""

    def __init__(self, max_bytes: int, max_files: int, allowed: Sequence[str]) -> None:
        self.max_bytes, self.max_files, self.allowed = max_bytes, max_files, allowed
        self.files: dict[str, bytes] = {}
        self.total = 0
        self.dropped: list[str] = []

    def add(self, item: object) -> None:
        """Take one ``{"name": ..., "data": <base64>}`` entry, or note why not."""
        name = item.get("name") if isinstance(item, dict) else None
        problem = name_problem(name, self.allowed)
        if problem is None and isinstance(name, str):  # name_problem takes text names only
            problem = self._limit_problem(name)
            data = None if problem else _decoded(item)
            if data is None:
                problem = problem or "its data is not base64"
            elif self.total + len(data) > self.max_bytes:
                problem = (f"outputs would exceed SandboxSettings.output_max_bytes "
                           f"({self.max_bytes})")
            else:
                self.files[name] = data
                self.total += len(data)
                return
        self.dropped.append(f"dropped output {shown(name)}: {problem}")

    def _limit_problem(self, name: str) -> str | None:
        if name in self.files:
            return "listed twice"
        if len(self.files) >= self.max_files:
            return f"more than SandboxSettings.output_max_files ({self.max_files}) outputs"
        return None

    def warnings(self) -> list[str]:
        """One line per dropped output, the first ``MAX_WARNINGS`` of them and a count."""
        extra = len(self.dropped) - MAX_WARNINGS
        more = [f"... and {extra} more outputs dropped"] if extra > 0 else []
        return self.dropped[:MAX_WARNINGS] + more


def _decoded(item: object) -> bytes | None:
    data = item.get("data") if isinstance(item, dict) else None
    if not isinstance(data, str):
        return None
    try:
        return base64.b64decode(data, validate=True)
    except (binascii.Error, ValueError):
        return None


def _files(value: object, max_bytes: int, max_files: int,
           allowed: Sequence[str]) -> tuple[dict[str, bytes], list[str]]:
    if value is None:
        return {}, []
    if not isinstance(value, list):
        raise ReportInvalid("the report's files are not a list")
    intake = _Intake(max_bytes, max_files, allowed)
    for item in value:
        intake.add(item)
    return intake.files, intake.warnings()


def write_files(files: dict[str, bytes], out_dir: Path) -> list[Path]:
    """Write vetted (plain) names into ``out_dir`` atomically, never through a link."""
    written = []
    for name, data in files.items():
        target = out_dir / name
        write_bytes_atomic(target, data)  # replaces a link of that name, never writes through it
        written.append(target)
    return written

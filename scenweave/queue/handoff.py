"""A finished scenario folder as one compressed parcel, for a worker on another machine to hand
back through the queue.

``pack`` puts every regular file of the folder (sub-folders such as ``variants/v01/``
included) into a gzip-compressed tar; a file over ``Limits.file_bytes``, or one that would take
the parcel past ``Limits.total_bytes``, is left out and listed in ``Parcel.dropped`` (name,
size, why), so the outcome can say so. ``unpack`` writes a parcel into an empty folder and
accepts only plain relative paths of regular files and folders: no links, devices, absolute
paths or ``..``, whatever the parcel says.
"""

from __future__ import annotations

import io
import tarfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from scenweave.errors import InfrastructureError

MIB = 1024 * 1024


class ParcelError(InfrastructureError):
    """A parcel that cannot be unpacked (corrupt, or a member that is not a plain file)."""


@dataclass(frozen=True)
class Limits:
    """How large an artefact, and a whole scenario folder, may travel back (uncompressed)."""

    file_bytes: int = 16 * MIB
    total_bytes: int = 64 * MIB


@dataclass
class Parcel:
    """The compressed folder and what was left out of it."""

    data: bytes
    files: int = 0
    dropped: list[dict] = field(default_factory=list)


def dropped_entry(name: str, size: int, limit: int, what: str) -> dict:
    """One artefact left behind, with the setting that would have let it travel."""
    return {"file": name, "bytes": size,
            "reason": f"{what} is over {limit} bytes (raise submit --max-artefact-mb)"}


def pack(folder: Path, limits: Limits = Limits(),
         extra: Callable[[list[dict]], dict[str, bytes]] | None = None) -> Parcel:
    """Every regular file under ``folder`` that fits the limits, as a ``.tar.gz`` in memory.

    ``extra(dropped)`` returns files (name -> bytes) added last, whatever their size, knowing
    what was left out: the outcome that says so travels with the folder.
    """
    folder = Path(folder)
    buffer, parcel = io.BytesIO(), Parcel(b"")
    files, parcel.dropped = _fitting(folder, limits)
    added = extra(parcel.dropped) if extra else {}
    with tarfile.open(fileobj=buffer, mode="w:gz", compresslevel=6) as tar:
        for name, path in files:
            if name in added:
                continue
            info = tar.gettarinfo(str(path), arcname=name)
            info.uid = info.gid = 0
            info.uname = info.gname = ""
            with open(path, "rb") as handle:
                tar.addfile(info, handle)
        for name, content in added.items():
            info = tarfile.TarInfo(name)
            info.size, info.mode = len(content), 0o644
            tar.addfile(info, io.BytesIO(content))
    parcel.files = len(files) + len(set(added) - {name for name, _ in files})
    parcel.data = buffer.getvalue()
    return parcel


def _fitting(folder: Path, limits: Limits) -> tuple[list[tuple[str, Path]], list[dict]]:
    files, dropped, total = [], [], 0
    for path in sorted(folder.rglob("*")):
        if path.is_symlink() or not path.is_file():
            continue
        name, size = path.relative_to(folder).as_posix(), path.stat().st_size
        if size > limits.file_bytes:
            dropped.append(dropped_entry(name, size, limits.file_bytes, "the file"))
        elif total + size > limits.total_bytes:
            dropped.append(dropped_entry(name, size, limits.total_bytes,
                                         "the scenario folder with it"))
        else:
            total += size
            files.append((name, path))
    return files, dropped


def unpack(data: bytes, into: Path) -> list[str]:
    """Write the parcel's files into ``into`` (existing, empty); return their relative names."""
    into = Path(into)
    names = []
    try:
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
            for member in tar:
                target = into / _plain_path(member.name)
                if member.isdir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                if not member.isfile():
                    raise ParcelError(f"{member.name!r} is not a regular file")
                target.parent.mkdir(parents=True, exist_ok=True)
                source = tar.extractfile(member)
                target.write_bytes(source.read() if source else b"")
                target.chmod(member.mode & 0o755 | 0o600)
                names.append(member.name)
    except (tarfile.TarError, EOFError, OSError) as err:
        raise ParcelError(f"the parcel cannot be unpacked: {err}") from err
    return names


def _plain_path(name: str) -> PurePosixPath:
    path = PurePosixPath(name)
    if path.is_absolute() or not path.parts or any(p in ("", ".", "..") for p in path.parts):
        raise ParcelError(f"{name!r} is not a plain relative path")
    return path

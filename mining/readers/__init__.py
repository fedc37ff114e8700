"""Trajectory readers: each turns one public format into :class:`Recording`\\ s.

:func:`read_recordings` takes a file or a folder (walked recursively, in name order) and picks
the reader of each file by its name and first bytes. Nothing a file holds stops the walk: a file
no reader recognises, or one a reader fails on, comes back as a :class:`Recording` without
tracks whose ``warnings`` say why, and so does a folder where nothing was recognised. A
consumer therefore reports the ``warnings`` of every recording it gets.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Protocol

from scenweave.mining.readers import commonroad, highd, ngsim_csv
from scenweave.mining.tracks import Recording


class Reader(Protocol):
    """What a reader module offers: its format's name, whether a file is in its format, and
    the file read."""

    NAME: str

    def sniff(self, path: Path) -> bool: ...

    def read(self, path: Path) -> Recording: ...


#: in the order they are asked whether a file is theirs
READERS: tuple[Reader, ...] = (commonroad, highd, ngsim_csv)


def reader_for(path: Path) -> Reader | None:
    """The reader module whose ``sniff`` recognises ``path``, else ``None``."""
    return next((reader for reader in READERS if reader.sniff(path)), None)


def _note(source: Path, message: str) -> Recording:
    """A recording that only carries a warning."""
    return Recording(source=str(source), dt=0.0, tracks=[], warnings=[message])


def _files(path: Path) -> list[Path]:
    """The files under a folder in name order, without hidden files and folders."""
    return sorted(p for p in path.rglob("*") if p.is_file() and not any(
        part.startswith(".") for part in p.relative_to(path).parts))


def read_file(path: Path) -> Recording:
    """One file's recording; an unrecognised or unreadable file gives a warning instead."""
    path = Path(path)
    reader = reader_for(path)
    if reader is None:
        return _note(path, f"{path}: not a trajectory file this version reads (CommonRoad XML, "
                           "NGSIM table, highD NN_tracks.csv)")
    try:
        return reader.read(path)
    # what a malformed file raises: XML syntax errors are SyntaxErrors; commonroad-io checks
    # what it reads with assert
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, SyntaxError,
            AssertionError) as err:
        return _note(path, f"{path}: the {reader.NAME} reader could not read it: {err}")


def read_recordings(path: str | Path) -> Iterator[Recording]:
    """Every recording in ``path`` (a file or a folder); see the module's docstring for how
    what cannot be read is reported. A path that does not exist raises FileNotFoundError."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no such file or folder: {path}")
    if path.is_file():
        yield read_file(path)
        return
    recognised = 0
    for file in _files(path):
        if highd.companion(file):
            continue  # read with its NN_tracks.csv
        recording = read_file(file)
        recognised += bool(recording.reader)
        yield recording
    if not recognised:
        yield _note(path, f"{path}: no trajectory file recognised in this folder")

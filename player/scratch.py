"""The player's temporary folders, one per kind and process (scenario and map copies, esmini's
logs), under a scratch parent: the worker's own scratch folder (``use_scratch_parent``), else
``scenweave-scratch`` in the system's temp folder.

Each folder is named after the process that made it, by pid and start time (the sandbox's
``owner_tag``, which still names one process after its pid is reused): it goes when that
process exits (``atexit``), and when the process was killed, which runs no ``atexit``, the next
process making a folder under the same parent sweeps it (``sweep_dead``). Folders of live
processes are never touched.
"""

from __future__ import annotations

import atexit
import re
import shutil
import tempfile
import uuid
from pathlib import Path

from scenweave.sandbox.owner import owner_gone, owner_tag

#: ``<kind>-<pid>-<start time>-<random>``: the owner is the middle part
OWNED_NAME = re.compile(r"[a-z0-9_]+-(\d+-\d+)-[0-9a-f]{8}")
DEFAULT_PARENT_NAME = "scenweave-scratch"

_folders: dict[str, Path] = {}
_parent: Path | None = None


def scratch_parent() -> Path:
    """Where this process's scratch folders go (``use_scratch_parent``, else the default)."""
    return _parent or Path(tempfile.gettempdir()) / DEFAULT_PARENT_NAME


def use_scratch_parent(path: Path) -> None:
    """Make this process's scratch folders under ``path`` from now on (a worker's scratch)."""
    global _parent
    if _parent != Path(path):
        _parent = Path(path)
        _folders.clear()  # made again under the new parent on their next use


def scratch_folder(kind: str) -> Path:
    """This process's folder for ``kind`` (made on first use, again if it was removed)."""
    folder = _folders.get(kind)
    if folder is None or not folder.is_dir():
        folder = owned_folder(scratch_parent(), kind)
        atexit.register(shutil.rmtree, folder, True)
        _folders[kind] = folder
    return folder


def owned_folder(parent: Path, kind: str) -> Path:
    """A new folder ``parent/<kind>-<owner>-<random>`` owned by this process, made after the
    folders of dead owners under ``parent`` are swept."""
    parent.mkdir(parents=True, exist_ok=True)
    sweep_dead(parent)
    folder = parent / f"{kind}-{owner_tag()}-{uuid.uuid4().hex[:8]}"
    folder.mkdir()
    return folder


def sweep_dead(parent: Path) -> list[Path]:
    """Remove the owned folders under ``parent`` whose owning process has ended; return them."""
    swept = []
    for entry in sorted(parent.iterdir()) if parent.is_dir() else []:
        match = OWNED_NAME.fullmatch(entry.name)
        if match and entry.is_dir() and not entry.is_symlink() and owner_gone(match.group(1)):
            shutil.rmtree(entry, ignore_errors=True)
            swept.append(entry)
    return swept

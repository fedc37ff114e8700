"""The player's temporary folders, one per kind and process (scenario and map copies, esmini's
logs), removed when the process exits."""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

_folders: dict[str, Path] = {}


def scratch_folder(kind: str) -> Path:
    """This process's folder for ``kind`` (made on first use, again if it was removed)."""
    folder = _folders.get(kind)
    if folder is None or not folder.is_dir():
        folder = Path(tempfile.mkdtemp(prefix=f"scenweave-{kind}-"))
        atexit.register(shutil.rmtree, folder, True)
        _folders[kind] = folder
    return folder

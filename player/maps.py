"""The map copy esmini loads: CARLA's OpenDRIVE with what esmini cannot read taken out.

CARLA gives every traffic light ``value="-1"``; esmini looks light types up as
``type[.subtype][-value]`` and aborts on ``1000001--1``, so the copy drops ``value`` on dynamic
signals. Copies are written once per process into a temporary folder and reused.
"""

from __future__ import annotations

import atexit
import hashlib
import shutil
import tempfile
from pathlib import Path

from lxml import etree

_folder: Path | None = None
_prepared: dict[tuple, Path] = {}


def esmini_map(map_path: Path) -> Path:
    """A copy of ``map_path`` esmini can load (cached per process)."""
    map_path = Path(map_path).resolve()
    stat = map_path.stat()
    key = (str(map_path), stat.st_mtime_ns, stat.st_size)
    if key not in _prepared:
        tree = etree.parse(str(map_path))
        for signal in tree.getroot().iter("signal"):
            if signal.get("dynamic") == "yes":
                signal.attrib.pop("value", None)
        digest = hashlib.sha256(repr(key).encode()).hexdigest()[:12]
        target = _cache_folder() / f"{map_path.stem}-{digest}.xodr"
        tree.write(str(target), xml_declaration=True, encoding="utf-8")
        _prepared[key] = target
    return _prepared[key]


def _cache_folder() -> Path:
    global _folder
    if _folder is None or not _folder.is_dir():
        _folder = Path(tempfile.mkdtemp(prefix="scenweave-maps-"))
        atexit.register(shutil.rmtree, _folder, True)
    return _folder

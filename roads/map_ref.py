"""Which map: a bundled CARLA town by name or any OpenDRIVE file.

:func:`resolve_map` (defined here and nowhere else) turns what a user or a params dict says
(``"Town06"``, a path to an ``.xodr`` file, nothing = Town04) into a :class:`MapRef`: the
file, and the name a scenario's ``RoadNetwork/LogicFile`` gives it (``MapRef.logic_file``,
also the params key ``map``).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from scenweave.roads.bundled import BUNDLED_MAPS_DIR
from scenweave.roads.errors import UnknownMapError

#: the map a scenario is made for when nothing names one
DEFAULT_MAP = "Town04"
MAP_SUFFIX = ".xodr"


@dataclass(frozen=True)
class MapRef:
    """One map: its OpenDRIVE file and the name scenarios give it."""

    name: str
    path: Path
    #: one of the CARLA towns in ``roads/maps/`` (CARLA loads it by name)
    bundled: bool

    @property
    def logic_file(self) -> str:
        """What ``RoadNetwork/LogicFile filepath`` says (and params ``map``): a bundled town's
        name, which CARLA loads; for any other map the ``.xodr`` file's absolute path, which
        scenario_runner reads and loads as an OpenDRIVE-only world (and esmini opens)."""
        return self.name if self.bundled else str(self.path)

    @cached_property
    def sha256(self) -> str:
        """The map file's sha256 (hex)."""
        return hashlib.sha256(self.path.read_bytes()).hexdigest()


def bundled_maps() -> list[str]:
    """Names of the bundled towns, sorted."""
    return sorted(path.stem for path in BUNDLED_MAPS_DIR.glob(f"*{MAP_SUFFIX}"))


def resolve_map(value: str | Path | None = None) -> MapRef:
    """The map ``value`` names: a bundled town (``Town06``, any case), a path to an ``.xodr``
    file, or None/empty for the default Town04. Raises :class:`UnknownMapError` naming the
    bundled towns when the name is unknown or the file does not exist."""
    text = str(value or DEFAULT_MAP).strip()
    if text.lower().endswith(MAP_SUFFIX) or "/" in text or "\\" in text:
        return _map_file(Path(text).expanduser())
    by_lower = {name.lower(): name for name in bundled_maps()}
    name = by_lower.get(text.lower())
    if name is None:
        raise UnknownMapError(f"unknown map {text!r}: bundled maps are "
                              f"{', '.join(bundled_maps())}; or give a path to an "
                              f"OpenDRIVE {MAP_SUFFIX} file")
    return MapRef(name, BUNDLED_MAPS_DIR / f"{name}{MAP_SUFFIX}", bundled=True)


def _map_file(path: Path) -> MapRef:
    if not path.is_file():
        raise UnknownMapError(f"map file {str(path)!r} not found (a map is a bundled town, "
                              f"{', '.join(bundled_maps())}, or an OpenDRIVE {MAP_SUFFIX} file)")
    path = path.resolve()
    bundled = path.parent == BUNDLED_MAPS_DIR.resolve()
    return MapRef(path.stem, path, bundled=bundled)

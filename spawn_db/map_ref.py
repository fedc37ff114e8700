"""Which map: a bundled CARLA town by name or any OpenDRIVE file, and its spawn database.

Two definitions live here and nowhere else:

- :func:`resolve_map` turns what a user or a params dict says (``"Town06"``, a path to an
  ``.xodr`` file, nothing = Town04) into a :class:`MapRef`: the file, and the name a scenario's
  ``RoadNetwork/LogicFile`` gives it (``MapRef.logic_file``, also the params key ``map``);
- :func:`spawn_database` gives the spawn database of a map: the shipped ``Town04.json`` for
  the bundled Town04, otherwise a database built on first use and cached in ``cache_dir``
  under the map file's sha256 (a changed file gets a new database, an unchanged one never
  rebuilds).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path

from scenweave.errors import InputError
from scenweave.spawn_db.bundled import DEFAULT_DB_PATH, PACKAGE_DIR
from scenweave.spawn_db.errors import SpawnDbError

#: the CARLA towns that ship with ScenWeave (MIT, see maps/ATTRIBUTION.md)
BUNDLED_MAPS_DIR = PACKAGE_DIR / "maps"
#: the map a scenario is made for when nothing names one
DEFAULT_MAP = "Town04"
MAP_SUFFIX = ".xodr"


class UnknownMapError(SpawnDbError, InputError, ValueError):
    """A map name that is not bundled, or a map file that does not exist."""


@dataclass(frozen=True)
class MapRef:
    """One map: its OpenDRIVE file and the name scenarios give it."""

    name: str
    path: Path
    #: one of the CARLA towns in ``spawn_db/maps/`` (CARLA loads it by name)
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


def database_path(map_ref: MapRef, cache_dir: Path) -> Path:
    """Where the spawn database of ``map_ref`` lives (whether or not it exists yet).

    The shipped ``Town04.json`` serves the bundled Town04 (people's reviews live there);
    every other map's database is ``cache_dir/<name>-<sha256>.json``, so a changed map file
    gets its own.
    """
    if _shipped_sha256() == map_ref.sha256:
        return DEFAULT_DB_PATH
    return Path(cache_dir) / f"{map_ref.name}-{map_ref.sha256}.json"


def spawn_database(map_ref: MapRef, cache_dir: Path) -> Path:
    """The spawn database file of ``map_ref`` (:func:`database_path`), built on first use
    (written atomically) and read as it is on every later use."""
    path = database_path(map_ref, cache_dir)
    if not path.exists():
        from scenweave.spawn_db.database import build_database, write_database

        write_database(build_database(map_ref.path), path)
    return path


@cache
def _shipped_sha256() -> str:
    database = json.loads(DEFAULT_DB_PATH.read_text(encoding="utf-8"))
    sha256: str = database["metadata"]["source_sha256"]
    return sha256

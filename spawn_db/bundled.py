"""The map and database that ship with ScenWeave (CARLA Town04), loaded once per process."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from scenweave.spawn_db.opendrive import load_opendrive
from scenweave.spawn_db.road_network import RoadNetwork

PACKAGE_DIR = Path(__file__).resolve().parent
#: CARLA's Town04 OpenDRIVE map (CC-BY 4.0, see maps/ATTRIBUTION.md)
DEFAULT_MAP_PATH = PACKAGE_DIR / "maps" / "Town04.xodr"
#: the spawn database generated from it by ``scenweave spawn-db build``
DEFAULT_DB_PATH = PACKAGE_DIR / "Town04.json"


@cache
def _network(resolved: Path, mtime_ns: int) -> RoadNetwork:
    return RoadNetwork(load_opendrive(resolved))


def road_network(map_path: str | Path | None = None) -> RoadNetwork:
    """The lane graph of ``map_path`` (default: the bundled Town04), cached per file version."""
    path = Path(map_path or DEFAULT_MAP_PATH).resolve()
    mtime = path.stat().st_mtime_ns if path.exists() else 0
    return _network(path, mtime)

"""The default map that ships with ScenWeave (CARLA Town04), and every map's lane graph
loaded once per process."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from scenweave.roads.opendrive import load_opendrive
from scenweave.roads.road_network import RoadNetwork

#: the CARLA towns that ship with ScenWeave (MIT, see maps/ATTRIBUTION.md)
BUNDLED_MAPS_DIR = Path(__file__).resolve().parent / "maps"
#: CARLA's Town04 OpenDRIVE map, the map a scenario is made for when nothing names one
DEFAULT_MAP_PATH = BUNDLED_MAPS_DIR / "Town04.xodr"


@cache
def _network(resolved: Path, mtime_ns: int) -> RoadNetwork:
    return RoadNetwork(load_opendrive(resolved))


def road_network(map_path: str | Path | None = None) -> RoadNetwork:
    """The lane graph of ``map_path`` (default: the bundled Town04), cached per file version."""
    path = Path(map_path or DEFAULT_MAP_PATH).resolve()
    mtime = path.stat().st_mtime_ns if path.exists() else 0
    return _network(path, mtime)

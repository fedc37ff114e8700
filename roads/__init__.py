"""The road model: OpenDRIVE maps read, their lanes, lane graph, road graph and routes, and
map copies cut to a set of roads. It imports nothing of ScenWeave's but the error root.

Public API:
- ``resolve_map(name_or_path)`` -> ``MapRef`` (a bundled CARLA town by name, any ``.xodr``
  file by path; default Town04; ``UnknownMapError`` otherwise), ``bundled_maps()``,
  ``BUNDLED_MAPS_DIR``, ``DEFAULT_MAP``, ``DEFAULT_MAP_PATH``.
- ``road_network(map_path=None)`` -> ``RoadNetwork`` (the lane graph, cached per file
  version), ``load_opendrive(path)`` -> ``OpenDriveMap``.
- ``lane_position_to_world(road_id, lane_id, s, offset=0)`` -> ``(x, y, z, h)`` and
  ``advance_along_lane(road_id, lane_id, s, distance)`` -> ``(road_id, lane_id, s)`` on the
  bundled Town04 map or ``map_path=``, OpenSCENARIO frame (= OpenDRIVE frame);
  ``distance_along_lane(from_road, from_lane, from_s, to_road, to_lane, to_s)`` -> signed
  metres along the lane (``None`` when not reached); ``traffic_lights_carla()``
  (signal id -> CARLA x, y of every dynamic light, what ``pos=x,y`` resolves against).
- ``road_graph(map_path)`` -> ``RoadGraph``: roads as a graph of road ends (the roads reached
  along the straightest connections, near-shortest routes, roads near a point), and
  ``MapCutter(tree).cut(roads)``: the map's XML holding only some roads.
- Errors: ``RoadError`` (root), ``OpenDriveError``, ``LaneEndsError``, ``UnknownMapError``.
"""

from __future__ import annotations

from pathlib import Path

from scenweave.roads.bundled import BUNDLED_MAPS_DIR, DEFAULT_MAP_PATH, road_network
from scenweave.roads.errors import LaneEndsError, OpenDriveError, RoadError, UnknownMapError
from scenweave.roads.lanes import WorldPose
from scenweave.roads.map_cut import MapCutter
from scenweave.roads.map_ref import DEFAULT_MAP, MapRef, bundled_maps, resolve_map
from scenweave.roads.opendrive import OpenDriveMap, load_opendrive
from scenweave.roads.road_graph import RoadGraph, road_graph
from scenweave.roads.road_network import LanePoint, RoadNetwork
from scenweave.roads.signals import is_traffic_light, signal_position


def lane_position_to_world(road_id: int | str, lane_id: int, s: float, offset: float = 0.0,
                           map_path: str | Path | None = None
                           ) -> tuple[float, float, float, float]:
    """``(x, y, z, h)`` of a lane position, OpenSCENARIO frame; ``h`` along the lane's traffic.

    ``offset`` is lateral, along OpenDRIVE's ``t`` (positive = left of the road's reference
    direction). Default map: the bundled Town04.
    """
    pose = road_network(map_path).lane_to_world(road_id, lane_id, s, offset)
    return pose.x, pose.y, pose.z, pose.h


def advance_along_lane(road_id: int | str, lane_id: int, s: float, distance: float,
                       map_path: str | Path | None = None) -> tuple[int | str, int, float]:
    """The lane position ``distance`` metres further along the lane (negative: behind).

    The distance is measured along the lane centre, following successors across road and
    junction boundaries (straightest continuation). Raises :class:`LaneEndsError` if the
    drivable lane ends first.
    """
    point = road_network(map_path).advance(road_id, lane_id, s, distance)
    road = int(point.road_id) if point.road_id.lstrip("-").isdigit() else point.road_id
    return road, point.lane_id, point.s


def distance_along_lane(from_road_id: int | str, from_lane_id: int, from_s: float,
                        to_road_id: int | str, to_lane_id: int, to_s: float,
                        cap_m: float = 1000.0, map_path: str | Path | None = None
                        ) -> float | None:
    """Signed metres driven along the lane from one lane position to another.

    Positive when the second lies ahead in the driving direction, negative when behind;
    ``None`` when it is not on the same lane (followed across road and junction boundaries
    like :func:`advance_along_lane`) within ``cap_m``. Raises :class:`OpenDriveError` when the
    first position is not on the map.
    """
    start = LanePoint(str(from_road_id), int(from_lane_id), float(from_s))
    end = LanePoint(str(to_road_id), int(to_lane_id), float(to_s))
    return road_network(map_path).distance_between(start, end, cap_m)


def traffic_lights_carla(map_path: str | Path | None = None) -> dict[str, tuple[float, float]]:
    """Every dynamic traffic light of the map: signal id -> ``(x, y)`` in CARLA's frame.

    These are the positions a ``TrafficSignalStateAction name="pos=x,y"`` resolves against.
    """
    network = road_network(map_path)
    return {signal.id: _carla_xy(signal_position(network, signal))
            for road in network.map.roads.values() for signal in road.signals
            if is_traffic_light(signal)}


def _carla_xy(pose: WorldPose) -> tuple[float, float]:
    return pose.x, -pose.y


__all__ = [
    "BUNDLED_MAPS_DIR", "DEFAULT_MAP", "DEFAULT_MAP_PATH", "LaneEndsError", "LanePoint",
    "MapCutter", "MapRef", "OpenDriveError", "OpenDriveMap", "RoadError", "RoadGraph",
    "RoadNetwork", "UnknownMapError", "WorldPose", "advance_along_lane", "bundled_maps",
    "distance_along_lane", "lane_position_to_world", "load_opendrive", "resolve_map",
    "road_graph", "road_network", "traffic_lights_carla",
]

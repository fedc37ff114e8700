"""The spawn database: generated from an OpenDRIVE map, stored as JSON, reviewed by people.

``build_database`` places candidate spawn points on the map and describes each one in the
thesis Appendix D format (transform in CARLA's frame, geometry, surroundings, features,
annotations) plus what matching a manoeuvre needs: same-direction lanes to the left and
right and how far they go on, drivable length ahead and behind, the next signalised stop
line, the movements the junction ahead allows. Highway entries sit on the multi-lane
highway every ``HIGHWAY_SPACING_M``; urban entries on lanes approaching signalised
junctions, every ``URBAN_SPACING_M`` back from the stop line. The build is deterministic:
no clock, no randomness, fixed ordering and rounding.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import fastjsonschema
import numpy as np

from scenweave import maneuvers
from scenweave.files import write_text_atomic
from scenweave.roads.bundled import road_network
from scenweave.roads.errors import LaneEndsError
from scenweave.roads.lanes import lane_center_offset, lane_width
from scenweave.roads.map_ref import MapRef
from scenweave.roads.road_network import LaneKey, RoadNetwork
from scenweave.roads.signals import JunctionApproach, junction_approach, signal_position
from scenweave.spawn_db.errors import SpawnDatabaseError

DATABASE_SCHEMA = Path(__file__).with_name("spawn_db.schema.json")
#: the spawn database generated from the bundled Town04 by ``scenweave spawn-db build``
DEFAULT_DB_PATH = Path(__file__).resolve().parent / "Town04.json"

FORMAT_VERSION = 1
#: roads whose speed record is at least this are highway (km/h)
HIGHWAY_MIN_SPEED_KMH = 90.0
#: highway roads need this many same-direction driving lanes to get spawn points
HIGHWAY_MIN_LANES = 2
HIGHWAY_SPACING_M = 40.0
#: highway spawn points keep this far from the ends of their road (m)
ROAD_END_MARGIN_M = 10.0
URBAN_SPACING_M = 10.0
URBAN_MAX_STOP_LINE_M = 120.0
#: urban spawn points keep this far from where their lane enters the road (m)
URBAN_ENTRY_MARGIN_M = 3.0
#: walks stop here: a length of LENGTH_CAP_M means "at least that much"
LENGTH_CAP_M = 3000.0
#: straight/curve and junction features look this far ahead (m)
FEATURE_LOOKAHEAD_M = 100.0
#: a lane whose curvature stays under this over the lookahead is straight (1/m; radius 400 m)
STRAIGHT_MAX_CURVATURE = 1.0 / 400.0
#: in_lane_driving needs at least this much road ahead (m)
URBAN_MIN_DRIVABLE_M = 50.0
SIDES = ("left", "right")


@dataclass
class PathFacts:
    """What a walk from a spawn point found (distances along the lane, metres)."""

    length: float = 0.0
    side_m: dict[str, float] = field(default_factory=dict)
    max_curvature: float = 0.0
    junction_m: float | None = None
    intersection_m: float | None = None
    signal_m: float | None = None


def build_database(map_path: str | Path) -> dict[str, Any]:
    """Generate the spawn database of the OpenDRIVE map at ``map_path``."""
    map_path = Path(map_path)
    network = road_network(map_path)
    entries = [*_highway_entries(network), *_urban_entries(network)]
    for spawn_id, entry in enumerate(entries, start=1):
        entry["spawn_id"] = spawn_id
    return {
        "metadata": {
            "map": f"Carla/Maps/{map_path.stem}",
            "source_map": map_path.name,
            "source_sha256": hashlib.sha256(map_path.read_bytes()).hexdigest(),
            "format_version": FORMAT_VERSION,
            "generator": "scenweave spawn-db build",
            "frame": "CARLA world frame (left-handed): y = -y_opendrive, yaw = -heading, degrees",
            "length_cap_m": LENGTH_CAP_M,
            "spawn_point_count": len(entries),
        },
        "spawn_points": entries,
    }


def road_context(network: RoadNetwork, road_id: str) -> str:
    """``highway``, ``urban`` or ``rural`` for a (non-junction) road."""
    road = network.road(road_id)
    speeds = [limit for _, limit in road.speed_kmh]
    if speeds and max(speeds) >= HIGHWAY_MIN_SPEED_KMH:
        return "highway"
    sides = {lane_id > 0 for section in road.sections for lane_id, lane in section.lanes.items()
             if lane_id != 0 and lane.drivable}
    return "urban" if sides == {True, False} else "rural"


def _plain_roads(network: RoadNetwork, context: str) -> Iterator[str]:
    ids = [road_id for road_id, road in network.map.roads.items()
           if not road.in_junction and road_context(network, road_id) == context]
    yield from sorted(ids, key=lambda road_id: (len(road_id), road_id))


def _highway_entries(network: RoadNetwork) -> Iterator[dict[str, Any]]:
    for road_id in _plain_roads(network, "highway"):
        road = network.road(road_id)
        positions = np.arange(ROAD_END_MARGIN_M, road.length - ROAD_END_MARGIN_M + 1e-9,
                              HIGHWAY_SPACING_M)
        for lane_id in _lane_ids(network, road_id):
            for s in positions:
                key = network.key_at(road_id, lane_id, float(s))
                if _same_direction_lanes(network, key) + 1 >= HIGHWAY_MIN_LANES:
                    yield _entry(network, "highway", key, float(s))


def _urban_entries(network: RoadNetwork) -> Iterator[dict[str, Any]]:
    for road_id in _plain_roads(network, "urban"):
        road = network.road(road_id)
        for lane_id in _lane_ids(network, road_id):
            last = len(road.sections) - 1 if lane_id < 0 else 0
            key = LaneKey(road_id, last, lane_id)
            approach = junction_approach(network, key)
            if approach is None or not approach.signalised:
                continue
            for distance in np.arange(URBAN_SPACING_M, URBAN_MAX_STOP_LINE_M + 1e-9,
                                      URBAN_SPACING_M):
                s = _s_before_stop_line(network, key, approach, float(distance))
                if s is None:
                    break
                yield _entry(network, "urban", network.key_at(road_id, lane_id, s), s, approach)


def _lane_ids(network: RoadNetwork, road_id: str) -> list[int]:
    lanes = {key.lane_id for key in network.drivable_lanes() if key.road_id == road_id}
    return sorted(lanes, key=lambda lane_id: (lane_id > 0, abs(lane_id)))


def _s_before_stop_line(network: RoadNetwork, key: LaneKey, approach: JunctionApproach,
                        distance: float) -> float | None:
    try:
        point = network.advance(key.road_id, key.lane_id, approach.stop_line_s, -distance)
    except LaneEndsError:
        return None
    road = network.road(key.road_id)
    entry_s = 0.0 if key.lane_id < 0 else road.length
    if point.road_id != key.road_id or abs(point.s - entry_s) < URBAN_ENTRY_MARGIN_M:
        return None
    return point.s


def _same_direction_lanes(network: RoadNetwork, key: LaneKey, side: str | None = None) -> int:
    count = 0
    for current_side in ([side] if side else SIDES):
        current = network.neighbour(key, current_side)
        while current is not None:
            count += 1
            current = network.neighbour(current, current_side)
    return count


def _entry(network: RoadNetwork, context: str, key: LaneKey, s: float,
           approach: JunctionApproach | None = None) -> dict[str, Any]:
    road = network.road(key.road_id)
    pose = network.lane_to_world(key.road_id, key.lane_id, s)
    ahead = walk_facts(network, key, s, forward=True)
    behind = walk_facts(network, key, s, forward=False)
    lights = _traffic_lights(network, approach, pose.x, pose.y)
    straight = ahead.max_curvature <= STRAIGHT_MAX_CURVATURE
    junction_near = (ahead.intersection_m is not None
                     and ahead.intersection_m <= FEATURE_LOOKAHEAD_M)
    signal_near = ahead.signal_m is not None and ahead.signal_m <= FEATURE_LOOKAHEAD_M
    lanes = {side: {"count": _same_direction_lanes(network, key, side),
                    "ahead_m": _round(ahead.side_m[side]),
                    "behind_m": _round(behind.side_m[side])} for side in SIDES}
    movements = sorted({m.movement for m in approach.movements}) if approach else []
    stop_line = ahead.junction_m if approach is not None else None
    entry: dict[str, Any] = {
        "spawn_id": 0,
        "context": context,
        "transform": {"x": _round(pose.x), "y": _round(-pose.y), "z": _round(pose.z),
                      "yaw": _round(_wrap_degrees(-math.degrees(pose.h)))},
        "geometry": {
            "road_id": _road_id_value(key.road_id), "lane_id": key.lane_id, "s": _round(s),
            "road_network": {"current_road_length_m": _round(road.length)},
            "lane_width_m": _round(float(lane_width(road, road.sections[key.section],
                                                    key.lane_id, np.array([s]))[0])),
            "curvature_1pm": _round(float(_lane_curvature(network, key, np.array([s]))[0])),
        },
        "surroundings": {
            "speed_limit_kmh": _round(road.speed_limit_kmh(s) or 0.0, 1),
            "traffic_lights": lights,
            "stop_line_distance_m": _round(stop_line) if stop_line is not None else None,
            "is_highway_layout": context == "highway" and lanes["left"]["count"]
            + lanes["right"]["count"] + 1 >= 3,
        },
        "features": {
            "is_junction": road.in_junction,
            "is_straight": straight,
            "is_curve": not straight,
            "is_intersection": junction_near,
            "is_intersection_w_traffic_light": signal_near,
        },
        "lanes": lanes,
        "drivable": {
            "ahead_m": _round(ahead.length), "behind_m": _round(behind.length),
            "intersection_ahead_m": _optional_round(ahead.intersection_m),
            "signal_ahead_m": _optional_round(ahead.signal_m),
            "movements": movements,
        },
        "annotations": {"suitable_for": [], "priority": 1, "manually_reviewed": False},
    }
    entry["annotations"]["suitable_for"] = _suitable_for(entry)
    entry["annotations"]["priority"] = _priority(entry)
    return entry


def walk_facts(network: RoadNetwork, key: LaneKey, s: float, forward: bool) -> PathFacts:
    """Walk from a lane position and collect the facts matching needs (see :class:`PathFacts`)."""
    facts = PathFacts()
    open_sides = set(SIDES)
    for segment in network.walk(key.road_id, key.lane_id, s, forward):
        for side in sorted(open_sides):
            if network.neighbour(segment.key, side) is None:
                facts.side_m[side] = facts.length
                open_sides.discard(side)
        if forward and facts.length < FEATURE_LOOKAHEAD_M and facts.junction_m is None:
            facts.max_curvature = max(facts.max_curvature, _max_curvature(
                network, segment.key, segment.s_from, segment.s_to,
                FEATURE_LOOKAHEAD_M - facts.length))
        facts.length += segment.length
        if forward:
            _note_junction(facts, junction_approach(network, segment.key))
        if facts.length >= LENGTH_CAP_M:
            facts.length = LENGTH_CAP_M
            break
    for side in open_sides:
        facts.side_m[side] = facts.length
    return facts


def _note_junction(facts: PathFacts, approach: JunctionApproach | None) -> None:
    """Record the first junction, intersection (branching or signalised) and light ahead."""
    if approach is None:
        return
    if facts.junction_m is None:
        facts.junction_m = facts.length
    if facts.intersection_m is None and (len(approach.movements) > 1 or approach.signalised):
        facts.intersection_m = facts.length
    if facts.signal_m is None and approach.signalised:
        facts.signal_m = facts.length


def _max_curvature(network: RoadNetwork, key: LaneKey, s_from: float, s_to: float,
                   budget: float) -> float:
    span = min(abs(s_to - s_from), budget)
    if span <= 0:
        return 0.0
    direction = 1.0 if s_to >= s_from else -1.0
    samples = s_from + direction * np.linspace(0.0, span, max(2, math.ceil(span / 2.0) + 1))
    return float(np.abs(_lane_curvature(network, key, samples)).max())


def _lane_curvature(network: RoadNetwork, key: LaneKey, s: np.ndarray) -> np.ndarray:
    """Signed curvature of the lane centre as driven (1/m, positive = turning left)."""
    road = network.road(key.road_id)
    curvature = road.plan_view.pose(s).curvature
    t, _ = lane_center_offset(road, road.sections[key.section], key.lane_id, s)
    lane_curvature: np.ndarray = curvature / (1.0 - curvature * t)
    return lane_curvature if key.lane_id < 0 else -lane_curvature


def _traffic_lights(network: RoadNetwork, approach: JunctionApproach | None, x: float,
                    y: float) -> list[dict[str, Any]]:
    if approach is None:
        return []
    by_signal: dict[str, list[str]] = {}
    for movement in approach.movements:
        if movement.signal is not None:
            by_signal.setdefault(movement.signal.id, []).append(movement.movement)
    lights = []
    for signal_id, movements in by_signal.items():
        position = signal_position(network, network.map.signal(signal_id))
        lights.append({
            "signal_id": _road_id_value(signal_id),
            "x": _round(position.x), "y": _round(-position.y),
            "distance_m": _round(math.hypot(position.x - x, position.y - y)),
            "movements": sorted(set(movements)),
        })
    return sorted(lights, key=lambda light: (light["distance_m"], str(light["signal_id"])))


def _suitable_for(entry: dict[str, Any]) -> list[str]:
    """The urban tags the entry suits when the database is built (the thesis format's
    ``suitable_for``, for a person to review); the matcher asks :func:`suits_urban` anew, so a
    class registered later spawns too."""
    tags: list[str] = []
    for maneuver in maneuvers.maneuvers("urban"):
        if suits_urban(entry, maneuver) and maneuver.tag not in tags:
            tags.append(maneuver.tag)
    return tags


def suits_urban(entry: dict[str, Any], maneuver: maneuvers.Maneuver) -> bool:
    """Whether an urban class can start at ``entry``: a light class needs a light over its
    movement (straight on, right turn), any other class enough drivable road ahead."""
    if entry["context"] != "urban":
        return False
    if maneuver.light is None:
        return bool(entry["drivable"]["ahead_m"] >= URBAN_MIN_DRIVABLE_M)
    return any(maneuver.turn in light["movements"]
               for light in entry["surroundings"]["traffic_lights"])


def _priority(entry: dict[str, Any]) -> int:
    """1..3: one point each for a straight road and for the most useful surroundings."""
    priority = 1 + int(entry["features"]["is_straight"])
    if entry["context"] == "highway":
        lanes = entry["lanes"]
        priority += int(lanes["left"]["count"] > 0 and lanes["right"]["count"] > 0)
    else:
        priority += int(20.0 <= (entry["surroundings"]["stop_line_distance_m"] or 0.0) <= 60.0)
    return priority


def _round(value: float, digits: int = 4) -> float:
    rounded = round(float(value), digits)
    return 0.0 if rounded == 0 else rounded  # no "-0.0" in the file


def _optional_round(value: float | None) -> float | None:
    return None if value is None else _round(value)


def _wrap_degrees(angle: float) -> float:
    return (angle + 180.0) % 360.0 - 180.0


def _road_id_value(road_id: str) -> int | str:
    return int(road_id) if road_id.lstrip("-").isdigit() else road_id


# --- files ------------------------------------------------------------------------------------
def write_database(database: dict[str, Any], path: str | Path) -> None:
    """Validate ``database`` against its JSON Schema and write it atomically to ``path``."""
    validate_database(database, Path(path))
    text = json.dumps(database, indent=1, ensure_ascii=False) + "\n"
    write_text_atomic(Path(path), text)


def load_database(path: str | Path) -> dict[str, Any]:
    """Read and validate a spawn database file."""
    path = Path(path)
    try:
        database: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as err:
        raise SpawnDatabaseError(f"{path}: spawn database not found; generate it with "
                                 "`scenweave spawn-db build`") from err
    except (OSError, json.JSONDecodeError) as err:
        raise SpawnDatabaseError(f"{path}: cannot read the spawn database ({err})") from err
    validate_database(database, path)
    return database


@cache
def _database_schema() -> dict[str, Any]:
    schema: dict[str, Any] = json.loads(DATABASE_SCHEMA.read_text(encoding="utf-8"))
    return schema


@cache
def _compiled_schema() -> Callable[[dict[str, Any]], Any]:
    check: Callable[[dict[str, Any]], Any] = fastjsonschema.compile(_database_schema())
    return check


def validate_database(database: dict[str, Any], path: Path) -> None:
    """Check ``database`` against ``spawn_db/spawn_db.schema.json``; unique spawn ids.

    The compiled check answers in ~20 ms where jsonschema takes about a second (every command
    that places scenarios loads the database); jsonschema then names the most relevant error.
    """
    try:
        _compiled_schema()(database)
    except fastjsonschema.JsonSchemaException:
        import jsonschema  # here: 0.2 s to import, needed only to explain a failure

        error = jsonschema.exceptions.best_match(
            jsonschema.Draft202012Validator(_database_schema()).iter_errors(database))
        where, message = "(root)", "does not match spawn_db/spawn_db.schema.json"
        if error is not None:
            where = "/".join(str(part) for part in error.absolute_path) or "(root)"
            message = error.message
        raise SpawnDatabaseError(f"{path}: {where}: {message}") from None
    ids = [entry["spawn_id"] for entry in database["spawn_points"]]
    if len(ids) != len(set(ids)):
        raise SpawnDatabaseError(f"{path}: spawn_id values are not unique")


def carry_reviews(database: dict[str, Any], previous: dict[str, Any]) -> int:
    """Copy ``manually_reviewed`` marks from ``previous`` onto entries at the same lane position.

    A rebuild must not throw away a person's review. Returns how many marks were carried.
    """
    def place(entry: dict[str, Any]) -> tuple[str, int, float]:
        geometry = entry["geometry"]
        return geometry["road_id"], geometry["lane_id"], geometry["s"]

    reviewed = {place(e) for e in previous["spawn_points"] if e["annotations"]["manually_reviewed"]}
    carried = 0
    for entry in database["spawn_points"]:
        if place(entry) in reviewed:
            entry["annotations"]["manually_reviewed"] = True
            carried += 1
    return carried


def mark_reviewed(path: str | Path, spawn_ids: Iterable[int], reviewed: bool = True) -> int:
    """Set ``annotations.manually_reviewed`` of the given entries; returns how many changed."""
    path = Path(path)
    database = load_database(path)
    wanted = set(spawn_ids)
    known = {entry["spawn_id"] for entry in database["spawn_points"]}
    unknown = sorted(wanted - known)
    if unknown:
        raise SpawnDatabaseError(f"{path}: no spawn point with spawn_id {unknown}")
    changed = 0
    for entry in database["spawn_points"]:
        if entry["spawn_id"] in wanted and entry["annotations"]["manually_reviewed"] != reviewed:
            entry["annotations"]["manually_reviewed"] = reviewed
            changed += 1
    write_database(database, path)
    return changed


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
    (written atomically) and read as it is on every later use: the shipped ``Town04.json``
    for the bundled Town04, otherwise a database cached in ``cache_dir`` under the map
    file's sha256 (a changed file gets a new database, an unchanged one never rebuilds)."""
    path = database_path(map_ref, cache_dir)
    if not path.exists():
        write_database(build_database(map_ref.path), path)
    return path


@cache
def _shipped_sha256() -> str:
    database = json.loads(DEFAULT_DB_PATH.read_text(encoding="utf-8"))
    sha256: str = database["metadata"]["source_sha256"]
    return sha256

"""The map copy esmini loads: CARLA's OpenDRIVE with what esmini cannot read taken out, cut to
the roads a scenario plays on.

CARLA gives every traffic light ``value="-1"``; esmini looks light types up as
``type[.subtype][-value]`` and aborts on ``1000001--1``, so every copy drops ``value`` on
dynamic signals.

Loading the map is most of a replay's cost: esmini builds points every metre along every lane
of every road (Town04: 10.8 km of roads, 0.45-1.2 s per ``SE_InitWithArgs``, while stepping
20 s costs under 0.02 s), so the cost follows the length of road loaded. A scenario therefore
plays on a copy holding only the roads it is expected on (``plan_cut`` decides, ``cut_map``
writes):

- each entity starts where its teleports put it: a ``LanePosition`` or ``RoadPosition`` is
  its road and ``s``, moving with its lane's traffic; a ``WorldPosition`` is every road
  passing within ``SEED_NEAR_M`` on which its heading drives with the traffic (and the
  nearest road either way);
- it drives at most its fastest speed (the largest speed its actions set; its ``Performance
  maxSpeed`` for relative speeds) times the time played (``REACH_SLACK``), plus
  ``REACH_MARGIN_M``; esmini moves ``s`` faster than the car on the inside of curves, which
  each road's ``s_rate`` bounds;
- at a junction it takes what esmini's default junction selector takes, from each lane that
  arrives there: the connection heading straightest on. A car with a routing target
  (``AcquirePositionAction``, ``AssignRouteAction``) follows every near-shortest route to it
  (esmini routes along the shortest), and past it the first connection listed as well (what
  esmini takes once a route has ended);
- the *core* is every road those walks enter; the copy *keeps* the core, every road touching
  an end a walk drives through (so each junction offers the same connections), the roads near
  every position the scenario names (``NEAR_POINT_M``: esmini snaps world positions to the
  closest road) and the roads holding the lights it switches. Links and junction connections
  naming a dropped road are removed, so esmini loads the copy cleanly.

The walks are a prediction; what makes the cut safe is the check after the replay
(``MapCut.covers``): a copy played like the whole map as long as every entity stayed on core
roads and never drove up to an end whose neighbours were not all kept (``guarded``), which
each entity's road, lane and ``s`` at every step show. ``player.replay`` plays a scenario that
did not again on the whole map. Constructs whose reach cannot be bounded (trajectories,
controllers, relative world positions, parameters in speeds or positions, ...) make
``plan_cut`` answer with the whole map and the reason.

Copies are written once per process into a temporary folder and reused, keyed by the map
file's identity (path, mtime, size) and the kept road set.
"""

from __future__ import annotations

import copy
import hashlib
import heapq
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lxml import etree

from scenweave.errors import ScenarioError
from scenweave.player.scratch import scratch_folder
from scenweave.roads.opendrive import DRIVABLE_LANE_TYPES

#: a WorldPosition starts an entity on every road passing this close (m)
SEED_NEAR_M = 20.0
#: every road passing this close to a WorldPosition is kept (m): esmini snaps to the closest
NEAR_POINT_M = 30.0
#: added to every entity's reach (m): its length, lane changes, rounding
REACH_MARGIN_M = 60.0
#: the reach is this much more than the fastest speed times the time played
REACH_SLACK = 1.05
#: ``s`` per metre driven is bounded as if no lane came closer to a curve's centre than
#: this share of its radius (esmini then looks the position up again)
MAX_BEND = 0.8
#: the reference lines are sampled this densely for the WorldPosition look-ups (m)
SAMPLE_STEP_M = 2.0
#: when the roads kept exceed this share of the map's road length the whole map is used
WHOLE_MAP_SHARE = 0.8
#: a heading within this of the road's (either way) fixes the direction of travel (rad)
HEADING_TOLERANCE = math.radians(60)
#: closer than this to the reference line a point's side does not tell its lane direction (m)
LAWFUL_SIDE_M = 0.5
#: junction connections this close to the straightest are all expected (rad)
TIE_TOLERANCE = math.radians(3)
#: a car driving this close to a guarded road end makes the replay suspect (m)
CLOSED_END_M = 1.0
#: routes up to this much longer than the shortest (plus the margin) are kept
ROUTE_SLACK = 1.5
ROUTE_MARGIN_M = 50.0

#: actions that move entities in ways the reach does not bound
UNBOUNDED_ACTIONS = {"FollowTrajectoryAction", "SynchronizeAction", "LongitudinalDistanceAction",
                     "LateralDistanceAction", "ControllerAction", "AssignControllerAction",
                     "OverrideControllerValueAction", "ActivateControllerAction",
                     "TrafficAction", "TrafficSourceAction", "TrafficSinkAction",
                     "TrafficSwarmAction", "TrafficStopAction", "TrafficAreaAction",
                     "SpeedProfileAction", "RandomRouteAction", "ParameterAction",
                     "VariableAction", "CustomCommandAction", "UserDefinedAction"}

_prepared: dict[tuple, Path] = {}
_indexes: dict[tuple, MapIndex] = {}
_cuts: dict[tuple, Path] = {}


# --- the whole map, prepared ------------------------------------------------------------------
def map_identity(map_path: Path) -> tuple:
    """What names one version of a map file: resolved path, mtime and size."""
    map_path = Path(map_path).resolve()
    stat = map_path.stat()
    return (str(map_path), stat.st_mtime_ns, stat.st_size)


def esmini_map(map_path: Path) -> Path:
    """A copy of the whole ``map_path`` esmini can load (cached per process)."""
    key = map_identity(map_path)
    if key not in _prepared:
        target = scratch_folder("maps") / f"{Path(key[0]).stem}-{_digest(key)}.xodr"
        _prepared_tree(Path(key[0])).write(str(target), xml_declaration=True, encoding="utf-8")
        _prepared[key] = target
    return _prepared[key]


def _prepared_tree(map_path: Path) -> etree._ElementTree:
    tree = etree.parse(str(map_path))
    for signal in tree.getroot().iter("signal"):
        if signal.get("dynamic") == "yes":
            signal.attrib.pop("value", None)
    return tree


# --- the road graph of a map ------------------------------------------------------------------
@dataclass
class MapIndex:
    """One map's roads as a graph of road ends, with sampled reference lines."""

    identity: tuple
    tree: etree._ElementTree
    #: road id -> its ``<road>`` element, in file order
    roads: dict[str, etree._Element]
    lengths: dict[str, float]
    #: road end ``(road id, 0 start | 1 end)`` -> the road ends it touches
    touches: dict[tuple[str, int], set[tuple[str, int]]]
    #: road id -> (has drivable lanes along s, has drivable lanes against s)
    drives: dict[str, tuple[bool, bool]]
    #: signal id -> road id holding the ``<signal>``
    signal_roads: dict[str, str]
    #: whether every road id is a number (esmini then reports roads by that number)
    numeric_ids: bool
    #: road end -> the road ends it continues into through a road link (not a junction)
    road_links: dict[tuple[str, int], list[tuple[str, int]]]
    #: road end at a junction -> incoming lane id -> (connecting road, end entered) options
    lane_options: dict[tuple[str, int], dict[int, list[tuple[str, int]]]]
    #: road end -> the drivable lanes whose traffic drives towards it
    toward: dict[tuple[str, int], set[int]]
    #: connecting road -> the incoming roads of its junction connections
    incoming: dict[str, set[str]]
    #: road id -> reference heading at its start and at its end
    end_headings: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: road id -> the most ``s`` a car covers there per metre driven (``_s_rate``)
    s_rate: dict[str, float] = field(default_factory=dict)
    #: sampled reference lines: x, y, heading, s and the road's position in ``road_order``
    sample_xy: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 2)))
    sample_hdg: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    sample_s: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    sample_road: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0, int))
    road_order: list[str] = field(default_factory=list)
    #: (road, end, routed) -> where traffic leaving there is expected to go
    choices: dict[tuple[str, int, bool], list[tuple[str, int]]] = field(default_factory=dict)
    #: the map's top-level elements, and serialised pieces the cut copies are made of
    children: list[etree._Element] = field(default_factory=list, repr=False)
    pieces: dict[tuple, object] = field(default_factory=dict, repr=False)

    @property
    def total_length(self) -> float:
        return sum(self.lengths.values())

    def roads_near(self, x: float, y: float, radius: float) -> dict[str, tuple[float, float]]:
        """Each road passing within ``radius`` of ``(x, y)`` (and always the nearest):
        road id -> ``(s, heading)`` of its sample nearest to the point."""
        if not len(self.sample_s):
            return {}
        d2 = np.sum((self.sample_xy - (x, y)) ** 2, axis=1)
        inside = np.flatnonzero(d2 <= radius * radius)
        if not len(inside):
            inside = np.array([int(np.argmin(d2))])
        found: dict[str, tuple[float, float]] = {}
        for i in inside[np.argsort(d2[inside], kind="stable")]:
            road = self.road_order[self.sample_road[i]]
            found.setdefault(road, (float(self.sample_s[i]), float(self.sample_hdg[i])))
        return found

    def heading_at(self, road: str, s: float) -> float | None:
        """The reference line's heading at (the sample nearest) ``s`` of ``road``."""
        if road not in self.roads:
            return None
        rows = np.flatnonzero(self.sample_road == self.road_order.index(road))
        if not len(rows):
            return None
        return float(self.sample_hdg[rows[np.argmin(np.abs(self.sample_s[rows] - s))]])


def map_index(map_path: Path) -> MapIndex:
    """The graph of ``map_path`` (cached per process and file version)."""
    identity = map_identity(map_path)
    if identity not in _indexes:
        _indexes[identity] = _build_index(identity)
    return _indexes[identity]


def _build_index(identity: tuple) -> MapIndex:
    tree = _prepared_tree(Path(identity[0]))
    root = tree.getroot()
    roads = {r.get("id"): r for r in root.iterfind("road")}
    lengths = {rid: float(r.get("length") or 0.0) for rid, r in roads.items()}
    touches: dict[tuple[str, int], set[tuple[str, int]]] = {
        (rid, end): set() for rid in roads for end in (0, 1)}
    connections = _junction_connections(root)

    def touch(a: tuple[str, int], b: tuple[str, int]) -> None:
        if a in touches and b in touches:
            touches[a].add(b)
            touches[b].add(a)

    road_links: dict[tuple[str, int], list[tuple[str, int]]] = {}
    lane_options: dict[tuple[str, int], dict[int, list[tuple[str, int]]]] = {}
    for rid, road in roads.items():
        for end, kind in ((0, "predecessor"), (1, "successor")):
            link = road.find(f"link/{kind}")
            if link is None:
                continue
            other = link.get("elementId")
            if link.get("elementType", "road") == "junction":
                options = lane_options.setdefault((rid, end), {})
                for incoming, connecting, contact, lanes in connections.get(other, ()):
                    if incoming != rid:
                        continue
                    for other_end in _contact_ends(contact):
                        touch((rid, end), (connecting, other_end))
                        for lane in lanes:
                            options.setdefault(lane, []).append((connecting, other_end))
            else:
                for other_end in _contact_ends(link.get("contactPoint")):
                    touch((rid, end), (other, other_end))
                    if other in roads:
                        road_links.setdefault((rid, end), []).append((other, other_end))
    drives = {rid: _drive_directions(road) for rid, road in roads.items()}
    toward = {(rid, end): _lanes_toward(road, end) for rid, road in roads.items()
              for end in (0, 1)}
    signal_roads = {s.get("id"): rid for rid, road in roads.items()
                    for s in road.iterfind("signals/signal")}
    numeric = all(rid is not None and rid.isdigit() for rid in roads)
    incoming: dict[str, set[str]] = {}
    for found in connections.values():
        for source, connecting, _, _ in found:
            incoming.setdefault(connecting, set()).add(source)
    index = MapIndex(identity, tree, roads, lengths, touches, drives, signal_roads,
                     numeric, road_links, lane_options, toward, incoming)
    index.children = list(root)
    _sample_reference_lines(index)
    return index


def _junction_connections(root: etree._Element
                          ) -> dict[str, list[tuple[str, str, str, list[int]]]]:
    """junction id -> (incoming road, connecting road, contact point, incoming lane ids) of
    each connection."""
    found: dict[str, list[tuple[str, str, str, list[int]]]] = {}
    for junction in root.iterfind("junction"):
        for c in junction.iterfind("connection"):
            connecting = c.get("connectingRoad") or c.get("linkedRoad")
            lanes = [int(link.get("from")) for link in c.iterfind("laneLink")
                     if (link.get("from") or "").lstrip("-").isdigit()]
            found.setdefault(junction.get("id"), []).append(
                (c.get("incomingRoad"), connecting, c.get("contactPoint"), lanes))
    return found


def _contact_ends(contact: str | None) -> tuple[int, ...]:
    return {"start": (0,), "end": (1,)}.get(contact or "", (0, 1))


def _drive_directions(road: etree._Element) -> tuple[bool, bool]:
    along = against = False
    for side, lanes in (("right", True), ("left", False)):
        for lane in road.iterfind(f"lanes/laneSection/{side}/lane"):
            kind = lane.get("type")
            if kind in DRIVABLE_LANE_TYPES:
                if kind == "bidirectional":
                    along = against = True
                elif lanes:
                    along = True
                else:
                    against = True
    return along, against


def _lanes_toward(road: etree._Element, end: int) -> set[int]:
    """The drivable lanes of the lane section at ``end`` whose traffic drives towards it."""
    sections = road.findall("lanes/laneSection")
    if not sections:
        return set()
    section = sections[-1] if end == 1 else sections[0]
    side = "right" if end == 1 else "left"
    return {int(lane.get("id")) for lane in section.iterfind(f"{side}/lane")
            if lane.get("type") in DRIVABLE_LANE_TYPES}


def _s_rate(road, s: np.ndarray, curvature: np.ndarray) -> float:
    """The most ``s`` a car on a drivable lane of ``road`` covers per metre driven: esmini
    moves it ``1 / (1 - curvature * t)`` of ``s`` per metre at lateral offset ``t``, which
    is largest at the outer border of the outermost drivable lane on the inside of a curve."""
    worst = 1.0
    for section in road.sections:
        inside = (s >= section.s_start) & (s <= section.s_end)
        if not inside.any():
            continue
        at = s[inside]
        for side in (1, -1):
            ids = sorted((i for i, lane in section.lanes.items()
                          if i * side > 0 and lane.type in DRIVABLE_LANE_TYPES), key=abs)
            if not ids:
                continue
            border = road.lane_offset.value(at).astype(float)
            for lane_id in range(side, ids[-1] + side, side):
                lane = section.lanes.get(lane_id)
                if lane is not None:
                    border = border + side * lane.width.value(at)
            bend = np.maximum(curvature[inside] * border, 0.0)
            worst = max(worst, float(np.max(1.0 / (1.0 - np.minimum(bend, MAX_BEND)))))
    return worst


def _sample_reference_lines(index: MapIndex) -> None:
    from scenweave import roads

    network = roads.road_network(index.identity[0])
    xy, hdg, ss, which = [], [], [], []
    for order, rid in enumerate(index.roads):
        index.road_order.append(rid)
        road = network.map.roads.get(rid)
        length = index.lengths[rid]
        if road is None or length <= 0:
            continue
        s = np.linspace(0.0, length, max(2, math.ceil(length / SAMPLE_STEP_M) + 1))
        pose = road.plan_view.pose(s)
        index.end_headings[rid] = (float(pose.hdg[0]), float(pose.hdg[-1]))
        index.s_rate[rid] = _s_rate(road, s, pose.curvature)
        xy.append(np.column_stack([pose.x, pose.y]))
        hdg.append(pose.hdg)
        ss.append(s)
        which.append(np.full(len(s), order))
    if xy:
        index.sample_xy = np.concatenate(xy)
        index.sample_hdg = np.concatenate(hdg)
        index.sample_s = np.concatenate(ss)
        index.sample_road = np.concatenate(which)


# --- what a scenario can reach ----------------------------------------------------------------
@dataclass(frozen=True)
class MapCut:
    """The roads a scenario plays on: ``roads`` (``None`` = the whole map) and why."""

    roads: frozenset[str] | None
    #: the roads the entities are expected on; a replay that leaves them is redone whole
    core: frozenset[str] = frozenset()
    #: (core road, end) -> the lanes in which a car reaching that end finds what the whole
    #: map has there: none where a neighbour was dropped (a dead end, or fewer junction
    #: connections); where only esmini's counter connections are missing (it derives them
    #: from roads not kept), the lanes with junction connections of their own
    guarded: Mapping[tuple[str, int], frozenset[int]] = field(default_factory=dict)
    #: each core road's length
    lengths: Mapping[str, float] = field(default_factory=dict)
    #: metres of road kept, and of the whole map
    kept_m: float = 0.0
    map_m: float = 0.0
    #: why the whole map is used (empty for a cut)
    reason: str = ""

    @property
    def whole(self) -> bool:
        return self.roads is None

    def covers(self, tracks: Mapping[str, Mapping[str, list]]) -> bool:
        """Whether every entity stayed on the core roads at every recorded step and never
        drove up to a guarded road end in a lane it does not allow (``tracks``:
        ``Playback.tracks``, esmini's road, lane and ``s``): then the cut map played exactly
        as the whole one."""
        if self.roads is None:
            return True
        core = {int(road): road for road in self.core}
        for track in tracks.values():
            before = None
            for road, lane, s in zip(track.get("road", ()), track.get("lane", ()),
                                     track.get("s", ()), strict=False):
                name = core.get(int(road))
                if name is None:
                    return False
                if before is not None and before[0] == road and s != before[1]:
                    end = 1 if s > before[1] else 0
                    near = (s >= self.lengths[name] - CLOSED_END_M if end else
                            s <= CLOSED_END_M)
                    allowed = self.guarded.get((name, end))
                    if near and allowed is not None and int(lane) not in allowed:
                        return False
                before = (road, s)
        return True


@dataclass
class _Entity:
    """What the scenario lets one entity do."""

    speeds: list[float] = field(default_factory=lambda: [0.0])
    relative_speed: bool = False
    max_speed: float | None = None
    #: the kind element of each teleport position, and whether it is in Init
    seeds: list[tuple[etree._Element, bool]] = field(default_factory=list)
    #: the kind element of each routing target (AcquirePosition, route waypoints)
    targets: list[etree._Element] = field(default_factory=list)


class _Unbounded(ScenarioError):
    """The scenario's reach cannot be bounded (names the construct)."""


#: a start point: road, s and the directions along s it may move
_Seed = tuple[str, float, tuple[int, ...]]


def plan_cut(scenario: etree._Element, map_path: Path, duration_s: float,
             signal_ids: Iterable[str] = ()) -> MapCut:
    """Which roads of ``map_path`` the scenario (an ``OpenSCENARIO`` element, esmini-ready)
    plays on within ``duration_s``; the whole map (with the reason) when that is not
    bounded."""
    index = map_index(map_path)
    whole_m = index.total_length

    def whole(reason: str) -> MapCut:
        return MapCut(None, kept_m=whole_m, map_m=whole_m, reason=reason)

    if not index.numeric_ids:
        return whole("road ids that are not numbers (esmini renumbers them)")
    if not math.isfinite(duration_s):
        return whole("no finite duration")
    try:
        entities, anchors = _read_scenario(scenario)
        core: set[str] = set()
        open_ends: set[tuple[str, int]] = set()
        kept: set[str] = set()
        for name, entity in entities.items():
            roads, ends = _entity_roads(index, name, entity, entities, duration_s)
            core |= roads
            open_ends |= ends
        if any(entity.targets for entity in entities.values()):
            kept |= _past_connections(index, open_ends)
        kept |= core
        for end in open_ends:
            kept.update(road for road, _ in index.touches[end])
        for kind in anchors:
            kept.update(_anchor_roads(index, kind))
    except _Unbounded as why:
        return whole(str(why))
    if not core:
        return whole("no entity starts on the map")
    kept.update(index.signal_roads[s] for s in signal_ids if s in index.signal_roads)
    kept_m = sum(index.lengths[r] for r in kept)
    if kept_m > WHOLE_MAP_SHARE * whole_m:
        return whole(f"the scenario reaches {kept_m / whole_m:.0%} of the map")
    guarded = {}
    for road in core:
        for end in (0, 1):
            if any(other not in kept for other, _ in index.touches[(road, end)]):
                guarded[(road, end)] = frozenset()
            elif _counter_connections_lost(index, road, end, kept):
                guarded[(road, end)] = frozenset(index.lane_options.get((road, end), ()))
    return MapCut(frozenset(kept), frozenset(core), guarded,
                  {road: index.lengths[road] for road in core}, kept_m, whole_m)


def _counter_connections_lost(index: MapIndex, road: str, end: int, kept: set[str]) -> bool:
    """Whether esmini would give ``road`` at ``end`` a junction connection on the whole map
    that it cannot derive on the copy: it adds the reverse of a connection (from the far end
    of its connecting road) when that connection's incoming road is loaded."""
    explicit = {c for options in index.lane_options.get((road, end), {}).values()
                for c, _ in options}
    return any(other not in explicit and any(a not in kept for a in index.incoming.get(other, ()))
               for other, _ in index.touches[(road, end)])


def _read_scenario(scenario: etree._Element) -> tuple[dict[str, _Entity], list[etree._Element]]:
    """Each entity's speeds, start positions and routing targets; every position named."""
    for element in scenario.iter():
        if _tag(element) in UNBOUNDED_ACTIONS:
            raise _Unbounded(f"{_tag(element)} moves entities beyond what the reach bounds")
        if element.get("coordinateSystem") in ("road", "lane", "trajectory") or \
                element.get("alongRoute") in ("true", "1"):
            # esmini measures these along the road graph, which the copy may not hold
            raise _Unbounded(f"{_tag(element)} measures along the roads")
    if scenario.find("Entities/EntitySelection") is not None:
        raise _Unbounded("an EntitySelection")
    entities: dict[str, _Entity] = {}
    for obj in scenario.iterfind("Entities/ScenarioObject"):
        performance = obj.find(".//Performance")
        limit = None if performance is None else abs(_number(performance, "maxSpeed"))
        entities[obj.get("name")] = _Entity(max_speed=limit)
    for action in scenario.iter("PrivateAction"):
        in_init = _ancestor(action, "Init") is not None
        for name in _actors(action, entities):
            _read_private(action, entities[name], in_init)
    for add in scenario.iter("AddEntityAction"):
        owner, position = add.getparent(), add.find("Position")
        name = owner.get("entityRef") if owner is not None else None
        if name not in entities or position is None:
            raise _Unbounded("an AddEntityAction without entity or position")
        entities[name].seeds.append((_position_kind(position), False))
    return entities, [_position_kind(p) for p in scenario.iter("Position")]


def _actors(action: etree._Element, entities: Mapping[str, _Entity]) -> list[str]:
    private = _ancestor(action, "Private")
    if private is not None:
        names = [private.get("entityRef")]
    else:
        group = _ancestor(action, "ManeuverGroup")
        if group is None:
            raise _Unbounded("a PrivateAction outside Init and ManeuverGroup")
        actors = group.find("Actors")
        if actors is None or actors.get("selectTriggeringEntities") in ("true", "1"):
            return list(entities)
        names = [ref.get("entityRef") for ref in actors.iterfind("EntityRef")]
    if any(name not in entities for name in names):
        raise _Unbounded(f"actors {names} are not all ScenarioObjects")
    return names


def _read_private(action: etree._Element, entity: _Entity, in_init: bool) -> None:
    for target in action.iter("SpeedActionTarget"):
        absolute = target.find("AbsoluteTargetSpeed")
        if absolute is not None:
            entity.speeds.append(_number(absolute, "value"))
        else:
            entity.relative_speed = True
    for position in action.iter("Position"):
        if _ancestor(position, "TeleportAction") is not None:
            entity.seeds.append((_position_kind(position), in_init))
        elif _ancestor(position, "RoutingAction") is not None:
            entity.targets.append(_position_kind(position))
        else:
            raise _Unbounded(f"a Position in a {_tag(action[0])}")


def _entity_roads(index: MapIndex, name: str, entity: _Entity, entities: Mapping[str, _Entity],
                  duration_s: float) -> tuple[set[str], set[tuple[str, int]]]:
    """The roads ``entity`` is expected on and the road ends it may drive through (their
    neighbours are kept): its reach along the straightest continuation at every junction
    (esmini's default choice), and the near-shortest routes to its routing targets followed
    by what esmini takes past them."""
    speed = max(abs(v) for v in entity.speeds)
    if entity.relative_speed:
        if entity.max_speed is None:
            raise _Unbounded(f"{name}: a relative speed and no Performance maxSpeed")
        speed = max(speed, entity.max_speed)
    reach = REACH_SLACK * speed * max(duration_s, 0.0) + REACH_MARGIN_M
    if not entity.seeds:
        raise _Unbounded(f"{name} has no start position")
    seeds: list[_Seed] = []
    extra = 0.0
    for kind, in_init in entity.seeds:
        found, more = _seed_points(index, kind, entities, duration_s, in_init)
        seeds += found
        extra = max(extra, more)
    reach += extra
    if entity.relative_speed or min(entity.speeds) < 0:  # it may reverse
        seeds = [(road, s, (1, -1)) for road, s, _ in seeds]
    roads, ends = _walk(index, seeds, reach)
    for kind in entity.targets:
        goal, _ = _seed_points(index, kind, entities, duration_s, True)
        route, to_goal = _route_roads(index, seeds, {road for road, _, _ in goal})
        # past the end of its route esmini takes the first connection listed, from the road
        # it puts the target on (the nearest); the car drove at least ``to_goal`` to get there
        after, after_ends = _walk(index, goal[:1], reach - min(to_goal, reach - REACH_MARGIN_M),
                                  routed=True)
        roads |= route | after
        ends |= after_ends | {(road, end) for road in route for end in (0, 1)}
    return roads, ends


def _past_connections(index: MapIndex, ends: set[tuple[str, int]]) -> set[str]:
    """The roads past the connecting roads of the junctions at ``ends``: on a route esmini
    picks the connection whose far end is the route's next road (none once past the target),
    so those roads must be loaded as on the whole map."""
    found: set[str] = set()
    for end in ends & index.lane_options.keys():
        for other, other_end in index.touches[end]:
            if other in index.incoming:
                found.update(road for road, _ in index.touches[(other, 1 - other_end)])
    return found


def _seed_points(index: MapIndex, kind: etree._Element, entities: Mapping[str, _Entity],
                 duration_s: float, in_init: bool) -> tuple[list[_Seed], float]:
    """Where a position puts an entity: ``(road, s, directions)`` candidates (the way its
    heading points, with its lane's traffic; both ways where that is unclear), and reach to
    add (relative positions)."""
    tag = _tag(kind)
    if tag in ("LanePosition", "RoadPosition"):
        road = _road_of(index, kind)
        s = min(max(_number(kind, "s"), 0.0), index.lengths[road])
        side = _number(kind, "laneId") if tag == "LanePosition" else -_number(kind, "t", 0.0)
        lawful = (1,) if side < 0 else (-1,) if side > 0 else (1, -1)
        orientation = kind.find("Orientation")
        if orientation is None or len(lawful) == 2:
            return [(road, s, lawful)], 0.0
        h = _number(orientation, "h", 0.0)
        if orientation.get("type") == "absolute":
            return [(road, s, _direction(h, index.heading_at(road, s)))], 0.0
        return [(road, s, _direction(h if lawful[0] > 0 else h + math.pi, 0.0))], 0.0
    if tag == "WorldPosition":
        x, y = _number(kind, "x"), _number(kind, "y")
        h = _number(kind, "h") if kind.get("h") is not None else None
        found = []
        for rank, (road, (s, heading)) in enumerate(index.roads_near(x, y, SEED_NEAR_M).items()):
            direction = (1, -1) if h is None else _direction(h, heading)
            if len(direction) == 1 and _lawful(index, road, s, x, y, direction[0]):
                found.append((road, s, direction))
            elif rank == 0:  # the nearest road, however the entity faces on it
                found.append((road, s, (1, -1)))
        return found, 0.0
    if tag in ("RelativeLanePosition", "RelativeRoadPosition"):
        ref = entities.get(kind.get("entityRef"))
        if ref is None or not ref.seeds or any(_tag(k).startswith("Relative")
                                               for k, _ in ref.seeds):
            raise _Unbounded(f"{tag} relative to an entity without an absolute start")
        offset = sum(abs(_number(kind, a, 0.0)) for a in ("ds", "dsLane", "dt", "offset"))
        offset += 5.0 * abs(_number(kind, "dLane", 0.0))
        if not in_init:  # the entity it names has moved since
            speed = max(max(abs(v) for v in ref.speeds), ref.max_speed or 0.0)
            offset += REACH_SLACK * speed * duration_s * max(index.s_rate.values(), default=1.0)
        found = []
        for ref_kind, ref_init in ref.seeds:
            points, _ = _seed_points(index, ref_kind, entities, duration_s, ref_init)
            found += [(road, s, (1, -1)) for road, s, _ in points]
        return found, offset
    raise _Unbounded(f"{tag} is not placed on the road graph")


def _lawful(index: MapIndex, road: str, s: float, x: float, y: float, direction: int) -> bool:
    """Whether moving ``direction`` along ``s`` at ``(x, y)`` drives with its lane's traffic
    (right of the reference line: along ``s``)."""
    along, against = index.drives[road]
    if not (along if direction > 0 else against):
        return False
    rows = np.flatnonzero(index.sample_road == index.road_order.index(road))
    row = rows[np.argmin(np.abs(index.sample_s[rows] - s))]
    heading = index.sample_hdg[row]
    px, py = index.sample_xy[row]
    side = -math.sin(heading) * (x - px) + math.cos(heading) * (y - py)
    if abs(side) < LAWFUL_SIDE_M:
        return True
    return (side < 0) == (direction > 0)


def _direction(h: float, road_heading: float | None) -> tuple[int, ...]:
    """Which way along ``s`` a heading ``h`` moves on a road heading ``road_heading``."""
    if road_heading is None:
        return (1, -1)
    difference = abs(_wrap(h - road_heading))
    if difference <= HEADING_TOLERANCE:
        return (1,)
    if difference >= math.pi - HEADING_TOLERANCE:
        return (-1,)
    return (1, -1)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _anchor_roads(index: MapIndex, kind: etree._Element) -> list[str]:
    """The roads esmini may resolve a position to (none for relative positions)."""
    tag = _tag(kind)
    if tag in ("LanePosition", "RoadPosition"):
        return [_road_of(index, kind)]
    if tag == "WorldPosition":
        return list(index.roads_near(_number(kind, "x"), _number(kind, "y"), NEAR_POINT_M))
    if tag in ("RelativeLanePosition", "RelativeRoadPosition"):
        return []
    raise _Unbounded(f"{tag} is not placed on the road graph")


def _road_of(index: MapIndex, kind: etree._Element) -> str:
    road = kind.get("roadId") or ""
    if road not in index.roads:
        raise _Unbounded(f"{_tag(kind)} roadId={road!r} is not a road of the map")
    return road


# --- walks over the road graph ----------------------------------------------------------------
def _leaving(index: MapIndex, seeds: Iterable[_Seed]) -> list[tuple[float, str, int]]:
    """The road ends the seeds drive to: ``(metres driven at least, road, end)``."""
    starts = []
    for road, s, directions in seeds:
        rate = index.s_rate.get(road, 1.0)
        for direction in directions:
            starts.append(((index.lengths[road] - s) / rate, road, 1) if direction > 0 else
                          (s / rate, road, 0))
    return starts


def _driven(index: MapIndex, road: str) -> float:
    """The fewest metres a car drives along the whole of ``road``."""
    return index.lengths[road] / index.s_rate.get(road, 1.0)


def _walk(index: MapIndex, seeds: list[_Seed], reach: float, routed: bool = False
          ) -> tuple[set[str], set[tuple[str, int]]]:
    """The roads entered within ``reach`` taking, at every junction and from every lane that
    arrives there, the connection esmini's default junction selector takes (the straightest,
    ties kept; with ``routed`` also the first one listed, which a car takes once past the end
    of its route); and the road ends driven through."""
    roads = {road for road, _, _ in seeds}
    queue = _leaving(index, seeds)
    heapq.heapify(queue)
    done: set[tuple[str, int]] = set()
    while queue:
        d, road, end = heapq.heappop(queue)
        if (road, end) in done or d > reach:
            continue
        done.add((road, end))
        for other, other_end in _choices(index, road, end, routed):
            roads.add(other)
            heapq.heappush(queue, (d + _driven(index, other), other, 1 - other_end))
    return roads, done


def _choices(index: MapIndex, road: str, end: int, routed: bool) -> list[tuple[str, int]]:
    """Where traffic leaving ``road`` at ``end`` goes: the linked road, or per incoming lane
    the junction connection whose exit heading is closest to the road's heading (esmini's
    junction selector angle 0), with ``routed`` also the lane's first connection."""
    key = (road, end, routed)
    if key in index.choices:
        return index.choices[key]
    if (road, end) in index.road_links:
        chosen = sorted(set(index.road_links[(road, end)]))
    else:
        options = index.lane_options.get((road, end), {})
        lanes = index.toward[(road, end)] & options.keys() or set(options)
        heading_in = index.end_headings[road][end] + (0.0 if end == 1 else math.pi)
        found: set[tuple[str, int]] = set()
        for lane in lanes:
            turns = [(abs(_wrap(_exit_heading(index, c, c_end) - heading_in)), (c, c_end))
                     for c, c_end in options[lane]]
            best = min(turn for turn, _ in turns)
            found.update(option for turn, option in turns if turn <= best + TIE_TOLERANCE)
            if routed:
                found.add(options[lane][0])
        chosen = sorted(found)
    index.choices[key] = chosen
    return chosen


def _exit_heading(index: MapIndex, road: str, entered: int) -> float:
    start, end = index.end_headings.get(road, (0.0, 0.0))
    return end if entered == 0 else start + math.pi


def _forward(index: MapIndex, seeds: list[_Seed]) -> dict[tuple[str, int], float]:
    """Metres driven from the nearest seed until entering each road at each end (Dijkstra
    over road ends, forward only, every junction connection, into a road only where it has
    drivable lanes leading away)."""
    entered: dict[tuple[str, int], float] = {}
    queue = _leaving(index, seeds)
    heapq.heapify(queue)
    done: set[tuple[str, int]] = set()
    while queue:
        d, road, end = heapq.heappop(queue)
        if (road, end) in done:
            continue
        done.add((road, end))
        for other, other_end in index.touches[(road, end)]:
            if not _enters(index, other, other_end):
                continue
            if d < entered.get((other, other_end), math.inf):
                entered[(other, other_end)] = d
                heapq.heappush(queue, (d + _driven(index, other), other, 1 - other_end))
    return entered


def _enters(index: MapIndex, road: str, end: int) -> bool:
    """Whether traffic may enter ``road`` at ``end`` (it has drivable lanes leading away)."""
    along, against = index.drives[road]
    return along if end == 0 else against


def _route_roads(index: MapIndex, seeds: list[_Seed], goal: set[str]) -> tuple[set[str], float]:
    """The roads on every forward route from the seeds into a ``goal`` road at most
    ``ROUTE_SLACK`` times (plus ``ROUTE_MARGIN_M``) longer than the shortest (esmini routes
    along the shortest, which the copy must hold), and the shortest's length (0 when a seed
    is on a goal road, infinite when none is reached)."""
    if any(road in goal for road, _, _ in seeds):
        return {road for road, _, _ in seeds}, 0.0
    ahead = _forward(index, seeds)
    shortest = min((d for (road, _), d in ahead.items() if road in goal), default=math.inf)
    if not math.isfinite(shortest):
        return set(), shortest
    budget = ROUTE_SLACK * shortest + ROUTE_MARGIN_M
    # metres from entering a road at an end until entering a goal road (Dijkstra backwards)
    behind: dict[tuple[str, int], float] = {}
    queue = [(0.0, road, end) for road in goal for end in (0, 1) if _enters(index, road, end)]
    heapq.heapify(queue)
    while queue:
        d, road, end = heapq.heappop(queue)
        if (road, end) in behind or d > budget:
            continue
        behind[(road, end)] = d
        for before, before_end in index.touches[(road, end)]:
            node = (before, 1 - before_end)  # entered at the other end, left at before_end
            if _enters(index, *node) and node not in behind:
                heapq.heappush(queue, (d + _driven(index, before), *node))
    found = {road for road, _, _ in seeds}
    found.update(road for (road, end), d in ahead.items()
                 if d + behind.get((road, end), math.inf) <= budget)
    return found, shortest


def _position_kind(position: etree._Element) -> etree._Element:
    kinds = [child for child in position if isinstance(child.tag, str)]
    if len(kinds) != 1:
        raise _Unbounded("a Position without exactly one kind")
    return kinds[0]


def _ancestor(element: etree._Element, tag: str) -> etree._Element | None:
    parent = element.getparent()
    while parent is not None and _tag(parent) != tag:
        parent = parent.getparent()
    return parent


def _tag(element: etree._Element) -> str:
    return etree.QName(element).localname if isinstance(element.tag, str) else ""


def _number(element: etree._Element, name: str, default: float | None = None) -> float:
    text = element.get(name)
    if text is None and default is not None:
        return default
    try:
        value = float(text or "")
    except ValueError:
        raise _Unbounded(f"{_tag(element)} {name}={text!r} is not a number") from None
    if not math.isfinite(value):
        raise _Unbounded(f"{_tag(element)} {name}={text!r} is not finite")
    return value


# --- writing a cut copy -----------------------------------------------------------------------
def cut_map(map_path: Path, roads: frozenset[str] | None) -> Path:
    """A copy of ``map_path`` esmini can load holding only ``roads`` (``None``: every road);
    cached per process by map file identity and road set."""
    if roads is None:
        return esmini_map(map_path)
    index = map_index(map_path)
    key = (index.identity, roads)
    if key not in _cuts:
        digest = _digest((index.identity, sorted(roads)))
        target = scratch_folder("maps") / f"{Path(index.identity[0]).stem}-cut-{digest}.xodr"
        target.write_bytes(cut_xml(index, roads))
        _cuts[key] = target
    return _cuts[key]


def cut_xml(index: MapIndex, roads: frozenset[str]) -> bytes:
    """The map with only ``roads``, their junctions (connections between kept roads) and the
    controllers of their signals; links to anything dropped removed. Assembled from the
    serialised pieces of the map, each made once per process."""
    junctions = {index.roads[r].get("junction") for r in roads if r in index.roads}
    signals = {sid for sid, rid in index.signal_roads.items() if rid in roads}
    opening, closing = _shell(index, ("root",), index.tree.getroot())
    parts = [b"<?xml version='1.0' encoding='utf-8'?>\n", opening]
    for position, child in enumerate(index.children):
        tag = child.tag if isinstance(child.tag, str) else ""
        if tag == "road":
            if child.get("id") in roads:
                parts.append(_road_bytes(index, position, child, roads, junctions))
        elif tag == "junction":
            if child.get("id") in junctions:
                parts.append(_filtered_bytes(index, position, child, "connection", lambda c: (
                    c.get("incomingRoad") in roads
                    and (c.get("connectingRoad") or c.get("linkedRoad")) in roads)))
        elif tag == "controller":
            kept = _filtered_bytes(index, position, child, "control",
                                   lambda c: c.get("signalId") in signals)
            if b"<control " in kept:
                parts.append(kept)
        else:
            parts.append(_piece(index, (position,), child))
    parts.append(closing)
    return b"".join(parts)


def _piece(index: MapIndex, key: tuple, element: etree._Element) -> bytes:
    """``element`` (at ``key``: its position in the map) serialised with its tail (cached)."""
    if ("piece", key) not in index.pieces:
        index.pieces[("piece", key)] = etree.tostring(element, encoding="utf-8", with_tail=True)
    return index.pieces[("piece", key)]


def _shell(index: MapIndex, key: tuple, element: etree._Element) -> tuple[bytes, bytes]:
    """``element``'s start tag (with its text) and end tag (with its tail), serialised."""
    if ("shell", key) not in index.pieces:
        marker = "SCENWEAVE-CUT-MARKER"
        shell = etree.Element(element.tag, dict(element.attrib))
        shell.text = marker
        opening, closing = etree.tostring(shell, encoding="utf-8").decode().split(marker)
        index.pieces[("shell", key)] = ((opening + (element.text or "")).encode(),
                                        (closing + (element.tail or "")).encode())
    return index.pieces[("shell", key)]


def _filtered_bytes(index: MapIndex, position: int, element: etree._Element, tag: str,
                    keep) -> bytes:
    """``element`` with only the ``tag`` children ``keep`` accepts (other children kept)."""
    opening, closing = _shell(index, (position,), element)
    parts = [opening]
    for inner, child in enumerate(element):
        if child.tag != tag or keep(child):
            parts.append(_piece(index, (position, inner), child))
    parts.append(closing)
    return b"".join(parts)


def _road_bytes(index: MapIndex, position: int, road: etree._Element, roads: frozenset[str],
                junctions: set[str | None]) -> bytes:
    """A kept road, without the links to dropped roads or junctions."""
    link = road.find("link")
    dropped = tuple(
        end.tag for end in (link if link is not None else ())
        if isinstance(end.tag, str) and end.get("elementId") not in (
            junctions if end.get("elementType", "road") == "junction" else roads))
    if not dropped:
        return _piece(index, (position,), road)
    key = ("road", position, dropped)
    if key not in index.pieces:
        trimmed = copy.deepcopy(road)
        trimmed_link = trimmed.find("link")
        for end in list(trimmed_link):
            if end.tag in dropped:
                trimmed_link.remove(end)
        index.pieces[key] = etree.tostring(trimmed, encoding="utf-8", with_tail=True)
    return index.pieces[key]


def _digest(key: tuple) -> str:
    return hashlib.sha256(repr(key).encode()).hexdigest()[:12]



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
  arrives there: the connection heading straightest on (``roads.RoadGraph.reach``). A car
  with a routing target (``AcquirePositionAction``, ``AssignRouteAction``) follows every
  near-shortest route to it (esmini routes along the shortest), and past it the first
  connection listed as well (what esmini takes once a route has ended);
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

The road graph, its walks and routes and the cut copies themselves are the road model's
(``scenweave.roads``: ``road_graph``, ``MapCutter``); this module decides what a scenario
needs. Copies are written once per process into a temporary folder and reused, keyed by the
map file's identity (path, mtime, size) and the kept road set.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from scenweave.errors import ScenarioError
from scenweave.player.scratch import scratch_folder
from scenweave.roads.lanes import normalize_angle
from scenweave.roads.map_cut import MapCutter
from scenweave.roads.road_graph import RoadEnd, RoadGraph, Start, road_graph

#: a WorldPosition starts an entity on every road passing this close (m)
SEED_NEAR_M = 20.0
#: every road passing this close to a WorldPosition is kept (m): esmini snaps to the closest
NEAR_POINT_M = 30.0
#: added to every entity's reach (m): its length, lane changes, rounding
REACH_MARGIN_M = 60.0
#: the reach is this much more than the fastest speed times the time played
REACH_SLACK = 1.05
#: when the roads kept exceed this share of the map's road length the whole map is used
WHOLE_MAP_SHARE = 0.8
#: a heading within this of the road's (either way) fixes the direction of travel (rad)
HEADING_TOLERANCE = math.radians(60)
#: closer than this to the reference line a point's side does not tell its lane direction (m)
LAWFUL_SIDE_M = 0.5
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

#: one version of a map file: resolved path, mtime (ns) and size
MapIdentity = tuple[str, int, int]

_prepared: dict[MapIdentity, Path] = {}
_cutters: dict[MapIdentity, MapCutter] = {}
_cuts: dict[tuple[MapIdentity, frozenset[str]], Path] = {}


# --- the whole map, prepared ------------------------------------------------------------------
def map_identity(map_path: Path) -> MapIdentity:
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
        if signal.get("dynamic") == "yes" and "value" in signal.attrib:
            del signal.attrib["value"]
    return tree


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
    guarded: Mapping[RoadEnd, frozenset[int]] = field(default_factory=dict)
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

    def covers(self, tracks: Mapping[str, Mapping[str, list[float]]]) -> bool:
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


def plan_cut(scenario: etree._Element, map_path: Path, duration_s: float,
             signal_ids: Iterable[str] = ()) -> MapCut:
    """Which roads of ``map_path`` the scenario (an ``OpenSCENARIO`` element, esmini-ready)
    plays on within ``duration_s``; the whole map (with the reason) when that is not
    bounded."""
    index = road_graph(map_path)
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
        open_ends: set[RoadEnd] = set()
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
    guarded: dict[RoadEnd, frozenset[int]] = {}
    for road in core:
        for side in (0, 1):
            if any(other not in kept for other, _ in index.touches[(road, side)]):
                guarded[(road, side)] = frozenset()
            elif _counter_connections_lost(index, road, side, kept):
                guarded[(road, side)] = frozenset(index.lane_options.get((road, side), ()))
    return MapCut(frozenset(kept), frozenset(core), guarded,
                  {road: index.lengths[road] for road in core}, kept_m, whole_m)


def _counter_connections_lost(index: RoadGraph, road: str, end: int, kept: set[str]) -> bool:
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
        name = obj.get("name")
        if name is None:
            raise _Unbounded("a ScenarioObject without a name")
        entities[name] = _Entity(max_speed=limit)
    for action in scenario.iter("PrivateAction"):
        in_init = _ancestor(action, "Init") is not None
        for name in _actors(action, entities):
            _read_private(action, entities[name], in_init)
    for add in scenario.iter("AddEntityAction"):
        owner, position = add.getparent(), add.find("Position")
        added = owner.get("entityRef") if owner is not None else None
        if added is None or added not in entities or position is None:
            raise _Unbounded("an AddEntityAction without entity or position")
        entities[added].seeds.append((_position_kind(position), False))
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
    known = [name for name in names if name is not None and name in entities]
    if len(known) != len(names):
        raise _Unbounded(f"actors {names} are not all ScenarioObjects")
    return known


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


def _entity_roads(index: RoadGraph, name: str, entity: _Entity, entities: Mapping[str, _Entity],
                  duration_s: float) -> tuple[set[str], set[RoadEnd]]:
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
    seeds: list[Start] = []
    extra = 0.0
    for kind, in_init in entity.seeds:
        found, more = _seed_points(index, kind, entities, duration_s, in_init)
        seeds += found
        extra = max(extra, more)
    reach += extra
    if entity.relative_speed or min(entity.speeds) < 0:  # it may reverse
        seeds = [(road, s, (1, -1)) for road, s, _ in seeds]
    roads, ends = index.reach(seeds, reach)
    for kind in entity.targets:
        goal, _ = _seed_points(index, kind, entities, duration_s, True)
        route, to_goal = index.routes(seeds, {road for road, _, _ in goal}, ROUTE_SLACK,
                                      ROUTE_MARGIN_M)
        # past the end of its route esmini takes the first connection listed, from the road
        # it puts the target on (the nearest); the car drove at least ``to_goal`` to get there
        after, after_ends = index.reach(goal[:1], reach - min(to_goal, reach - REACH_MARGIN_M),
                                       routed=True)
        roads |= route | after
        ends |= after_ends | {(road, end) for road in route for end in (0, 1)}
    return roads, ends


def _past_connections(index: RoadGraph, ends: set[RoadEnd]) -> set[str]:
    """The roads past the connecting roads of the junctions at ``ends``: on a route esmini
    picks the connection whose far end is the route's next road (none once past the target),
    so those roads must be loaded as on the whole map."""
    found: set[str] = set()
    for end in ends & index.lane_options.keys():
        for other, other_end in index.touches[end]:
            if other in index.incoming:
                found.update(road for road, _ in index.touches[(other, 1 - other_end)])
    return found


def _seed_points(index: RoadGraph, kind: etree._Element, entities: Mapping[str, _Entity],
                 duration_s: float, in_init: bool) -> tuple[list[Start], float]:
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
        facing = _number(kind, "h") if kind.get("h") is not None else None
        found: list[Start] = []
        for rank, (road, (s, heading)) in enumerate(index.roads_near(x, y, SEED_NEAR_M).items()):
            direction = (1, -1) if facing is None else _direction(facing, heading)
            if len(direction) == 1 and _lawful(index, road, s, x, y, direction[0]):
                found.append((road, s, direction))
            elif rank == 0:  # the nearest road, however the entity faces on it
                found.append((road, s, (1, -1)))
        return found, 0.0
    if tag in ("RelativeLanePosition", "RelativeRoadPosition"):
        ref_name = kind.get("entityRef")
        ref = entities.get(ref_name) if ref_name is not None else None
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


def _lawful(index: RoadGraph, road: str, s: float, x: float, y: float, direction: int) -> bool:
    """Whether moving ``direction`` along ``s`` at ``(x, y)`` drives with its lane's traffic
    (right of the reference line: along ``s``)."""
    along, against = index.drives[road]
    if not (along if direction > 0 else against):
        return False
    side = index.side_of(road, s, x, y)
    if abs(side) < LAWFUL_SIDE_M:
        return True
    return (side < 0) == (direction > 0)


def _direction(h: float, road_heading: float | None) -> tuple[int, ...]:
    """Which way along ``s`` a heading ``h`` moves on a road heading ``road_heading``."""
    if road_heading is None:
        return (1, -1)
    difference = abs(normalize_angle(h - road_heading))
    if difference <= HEADING_TOLERANCE:
        return (1,)
    if difference >= math.pi - HEADING_TOLERANCE:
        return (-1,)
    return (1, -1)


def _anchor_roads(index: RoadGraph, kind: etree._Element) -> list[str]:
    """The roads esmini may resolve a position to (none for relative positions)."""
    tag = _tag(kind)
    if tag in ("LanePosition", "RoadPosition"):
        return [_road_of(index, kind)]
    if tag == "WorldPosition":
        return list(index.roads_near(_number(kind, "x"), _number(kind, "y"), NEAR_POINT_M))
    if tag in ("RelativeLanePosition", "RelativeRoadPosition"):
        return []
    raise _Unbounded(f"{tag} is not placed on the road graph")


def _road_of(index: RoadGraph, kind: etree._Element) -> str:
    road = kind.get("roadId") or ""
    if road not in index.roads:
        raise _Unbounded(f"{_tag(kind)} roadId={road!r} is not a road of the map")
    return road


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
    identity = map_identity(map_path)
    key = (identity, roads)
    if key not in _cuts:
        digest = _digest((identity, sorted(roads)))
        target = scratch_folder("maps") / f"{Path(identity[0]).stem}-cut-{digest}.xodr"
        target.write_bytes(_cutter(identity).cut(roads))
        _cuts[key] = target
    return _cuts[key]


def _cutter(identity: MapIdentity) -> MapCutter:
    """The cutter of the map esmini loads (dynamic signals without ``value``), once per
    process and file version."""
    if identity not in _cutters:
        _cutters[identity] = MapCutter(_prepared_tree(Path(identity[0])))
    return _cutters[identity]


def _digest(key: tuple[object, ...]) -> str:
    return hashlib.sha256(repr(key).encode()).hexdigest()[:12]



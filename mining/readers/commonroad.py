"""CommonRoad scenario XML (read with the ``commonroad-io`` package), as the CommonRoad team
converted NGSIM US-101, Lankershim and Peachtree.

What the reader makes of it, and how far to trust it:

- One track per dynamic obstacle: rectangle length/width, ``time_step * dt``, position,
  orientation and velocity as given. Cars, taxis, priority and parked vehicles are cars;
  trucks and buses trucks; pedestrians, bicycles and other road users are skipped (counted
  in the warnings).
- ``lane`` is the lanelet the car's centre is in. Where lanelets overlap (boundaries,
  intersections) the one whose centre line is nearest and runs the car's way wins; a centre
  just outside every lanelet (up to :data:`MAX_OFF_MAP_M`) takes the nearest one; further out
  it is ``""``. All steps of a file are matched in one query against an R-tree of the
  lanelet polygons built once per file.
- ``s`` projects the position onto the axis of the lanelet's *direction group*: lanelets are
  grouped by the direction they run (within :data:`GROUP_ANGLE_DEG`), and each group's axis
  is the length-weighted mean direction of its centre lines, so it points along traffic. On a
  straight road (US-101) this is the road's axis, and gaps between cars of one road and
  direction are differences in ``s``. ``s`` never jumps: a step into another group, or one
  more than :data:`ALONG_AXIS_DEG` off its axis (inside a junction), advances it by the
  distance driven (:func:`continuous_s`). Where that left it more than :data:`SAME_FRAME_M`
  from the group's projection (after a turn), ``road`` gives the car a frame of its own, so
  no gap is measured between it and another car; else ``road`` is the direction group.
- ``lane_index`` counts same-direction ``adjacentLeft`` steps from the lanelet to the road's
  left edge (1 = leftmost); a lanelet without same-direction neighbours (an on-ramp, a turn
  inside an intersection) takes its predecessor's index, else its successor's. On a town's
  map (traffic lights or junctions) it changes only with :data:`MIN_LANE_CHANGE_M` of motion
  across the lane within :data:`LANE_CHANGE_WINDOW_S`, never inside a junction or while the
  car heads more than :data:`ACROSS_LANE_DEG` off its lane (:func:`held_lane_index`), and
  ``lateral`` is the motion across the lane summed against the lanelet's centre line
  (:func:`lane_lateral`).
- Traffic lights: one per ``trafficLight``, its lanes the lanelets that reference it, its stop
  line the ``s`` of those lanelets' stop lines (their ends where they have none) and, per lane,
  the stop line as a segment in the file's frame, the movements it controls (``direction``),
  its phases the cycle over the snippet's steps. ``redYellow`` counts as red (it still means stop);
  ``inactive`` (a turn arrow that is off) leaves a gap: that light says nothing then.
  Lights for different movements (``left``, ``straightRight``) can share an approach lanelet.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import shapely
from commonroad.common.file_reader import CommonRoadFileReader
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.traffic_light import TrafficLight as CrLight
from commonroad.scenario.traffic_light import TrafficLightState
from lxml import etree

from scenweave.mining.readers._common import (
    heading_from_motion,
    hold_last,
    skipped_warning,
    sort_tracks,
    vehicle_type,
)
from scenweave.mining.tracks import (
    Floats,
    LightPhase,
    Mask,
    Recording,
    Steps,
    Track,
    TrafficLight,
)

NAME = "commonroad"
GROUP_ANGLE_DEG = 45.0
#: a centre further than this outside every lanelet is off the map
MAX_OFF_MAP_M = 2.0
#: a lanelet running more than this against the car's heading is a poor match
WRONG_WAY_DEG = 60.0
WRONG_WAY_COST_M = 100.0
#: a car's ``s`` that strayed further than this from its group's axis projection (after a
#: turn) is compared with nobody else's
SAME_FRAME_M = 1.0
#: a step further off its group's axis advances ``s`` by the distance driven
ALONG_AXIS_DEG = 30.0
#: a step shorter than this is a standing car's jitter, whatever its direction
STILL_STEP_M = 0.05
#: a change of lanelet counts as a lane change only after this much motion across the road
#: within the last LANE_CHANGE_WINDOW_S
MIN_LANE_CHANGE_M = 1.5
LANE_CHANGE_WINDOW_S = 3.0
#: a car heading further than this off its lane is turning into or out of it
ACROSS_LANE_DEG = 25.0
#: shapely geometries, one per lanelet
Shapes = npt.NDArray[np.object_]
COLOURS = {
    TrafficLightState.GREEN: "green", TrafficLightState.YELLOW: "yellow",
    TrafficLightState.RED: "red", TrafficLightState.RED_YELLOW: "red",
}


def sniff(path: Path) -> bool:
    """An XML file whose root element is ``commonRoad``."""
    if path.suffix.lower() != ".xml":
        return False
    try:
        with path.open("rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    return b"<commonRoad" in head


@contextmanager
def _quiet_library() -> Iterator[None]:
    """commonroad-io logs a warning per old-format (2020a) intersection element, which is
    all of NGSIM's; they concern intersections, which the reader does not use."""
    logger = logging.getLogger("commonroad")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


# --- the lanelet map ------------------------------------------------------------------------

def _direction(centre: Floats) -> Floats:
    """Unit vector from a centre line's start to its end."""
    d = centre[-1] - centre[0]
    norm = np.hypot(*d)
    return d / norm if norm > 0 else np.array([1.0, 0.0])


def direction_groups(directions: Floats, lengths: Floats,
                     max_angle_deg: float = GROUP_ANGLE_DEG) -> tuple[Steps, Floats]:
    """Group unit ``directions`` (n, 2): the longest ungrouped lanelet seeds a group that takes
    every ungrouped one within ``max_angle_deg`` of it. Returns each lanelet's group and each
    group's axis (the length-weighted mean direction of its members)."""
    group = np.full(len(directions), -1)
    cos_max = np.cos(np.radians(max_angle_deg))
    axes: list[Floats] = []
    for seed in np.argsort(-lengths):
        if group[seed] >= 0:
            continue
        members = (group < 0) & (directions @ directions[seed] >= cos_max)
        group[members] = len(axes)
        mean = (directions[members] * lengths[members, None]).sum(axis=0)
        axes.append(mean / np.hypot(*mean))
    return group, np.array(axes).reshape(-1, 2)


def _lane_indices(network: LaneletNetwork) -> dict[int, int]:
    """Lanelet id -> lanes from the left edge of its road (1 = leftmost)."""
    def walk_left(lanelet: Lanelet) -> int:
        count, seen = 1, {lanelet.lanelet_id}
        while lanelet.adj_left is not None and lanelet.adj_left_same_direction:
            if lanelet.adj_left in seen:
                break
            seen.add(lanelet.adj_left)
            lanelet = network.find_lanelet_by_id(lanelet.adj_left)
            count += 1
        return count

    def alone(lanelet: Lanelet) -> bool:
        return not (lanelet.adj_left_same_direction and lanelet.adj_left is not None) and not (
            lanelet.adj_right_same_direction and lanelet.adj_right is not None)

    index = {ll.lanelet_id: walk_left(ll) for ll in network.lanelets}
    for ll in network.lanelets:
        if alone(ll):
            neighbours = [network.find_lanelet_by_id(i) for i in (*ll.predecessor, *ll.successor)]
            placed = [n for n in neighbours if n is not None and not alone(n)]
            if placed:
                index[ll.lanelet_id] = index[placed[0].lanelet_id]
    return index


@dataclass
class LaneMap:
    """A file's lanelets, ready for vectorised queries (built once per file)."""

    ids: list[int]
    polygons: Shapes
    centres: Shapes
    tree: shapely.STRtree
    group: Steps
    axes: Floats
    lane_index: Floats
    #: a town's map (junctions or traffic lights): lane indexes are held without lateral motion
    urban: bool = False
    junctions: frozenset[str] = frozenset()

    @classmethod
    def of(cls, network: LaneletNetwork) -> LaneMap:
        lanelets = list(network.lanelets)
        polygons = np.array([ll.polygon.shapely_object for ll in lanelets], dtype=object)
        centres = np.array([shapely.LineString(ll.center_vertices) for ll in lanelets],
                           dtype=object)
        directions = np.array([_direction(ll.center_vertices) for ll in lanelets]).reshape(-1, 2)
        group, axes = direction_groups(directions, shapely.length(centres).astype(float))
        if not len(axes):  # no lanelets: s runs along x
            axes = np.array([[1.0, 0.0]])
        index = _lane_indices(network)
        return cls(ids=[ll.lanelet_id for ll in lanelets], polygons=polygons, centres=centres,
                   tree=shapely.STRtree(polygons), group=group, axes=axes,
                   lane_index=np.array([index[ll.lanelet_id] for ll in lanelets], dtype=float))

    def locate(self, xy: Floats, heading: Floats) -> Steps:
        """The row of the lanelet each point is on (-1: off the map)."""
        points = shapely.points(xy)
        found = np.full(len(xy), -1)
        p, lane = self.tree.query(points, predicate="intersects")
        if len(p):
            cost = np.zeros(len(p))
            shared = np.bincount(p)[p] > 1  # only a point in several lanelets needs a choice
            cost[shared] = self._cost(points[p[shared]], lane[shared], heading[p[shared]])
            order = np.lexsort((cost, p))
            first = np.unique(p[order], return_index=True)[1]
            found[p[order][first]] = lane[order][first]
        missing = np.flatnonzero(found < 0)
        if len(missing):
            q, near = self.tree.query_nearest(points[missing], max_distance=MAX_OFF_MAP_M)
            first = np.unique(q, return_index=True)[1]  # of a tie, the first match
            found[missing[q[first]]] = near[first]
        return found

    def _cost(self, points: Shapes, lane: Steps, heading: Floats) -> Floats:
        """Distance to the lanelet's centre line, plus a penalty where it runs against the
        car's heading there."""
        centres = self.centres[lane]
        at = shapely.line_locate_point(centres, points)
        ahead = shapely.get_coordinates(shapely.line_interpolate_point(centres, at + 0.5))
        behind = shapely.get_coordinates(shapely.line_interpolate_point(centres, at - 0.5))
        along = ahead - behind
        run = np.arctan2(along[:, 1], along[:, 0])
        off = np.abs(np.angle(np.exp(1j * (heading - run))))
        wrong = np.nan_to_num(off, nan=0.0) > np.radians(WRONG_WAY_DEG)
        return shapely.distance(points, centres) + WRONG_WAY_COST_M * wrong

    def s(self, xy: Floats, group: Steps) -> Floats:
        """Position along each point's direction group's axis."""
        return np.einsum("ij,ij->i", xy, self.axes[group])


# --- tracks ---------------------------------------------------------------------------------

@dataclass
class _Raw:
    """One obstacle's states as arrays, before lanes are known."""

    id: str
    length: float
    width: float
    kind: str
    step: Floats
    xy: Floats
    heading: Floats
    speed: Floats


#: what the fast path reads of each state, under the state element
STATE_FIELDS = {"step": "time/exact", "x": "position/point/x", "y": "position/point/y",
                "heading": "orientation/exact", "speed": "velocity/exact"}


def _all_floats(root: etree._Element, path: str) -> Floats:
    """The number under ``path`` of every obstacle state in the file, in document order (an
    obstacle's initial state, then its trajectory)."""
    query = " | ".join(f"dynamicObstacle/{state}/{path}/text()"
                       for state in ("initialState", "trajectory/state"))
    return np.array(root.xpath(query), dtype=float)


def _parsed_size(element: etree._Element) -> tuple[float, float] | None:
    if element.find("shape/rectangle") is not None:
        return (_required_float(element, "shape/rectangle/length"),
                _required_float(element, "shape/rectangle/width"))
    if element.find("shape/circle") is not None:
        diameter = 2 * _required_float(element, "shape/circle/radius")
        return diameter, diameter
    return None


def _required_float(element: etree._Element, path: str) -> float:
    """The number under ``path``; ``ValueError`` where it is missing or no number."""
    text = element.findtext(path)
    if text is None:
        raise ValueError(f"{element.tag} {element.get('id')}: no {path}")
    return float(text)


def _state_count(obstacle: etree._Element) -> int:
    """How many states (the initial one and its trajectory's) an obstacle element holds."""
    count = obstacle.xpath("count(initialState | trajectory/state)")
    if not isinstance(count, float):  # XPath's count() is a number
        raise TypeError(f"XPath count() gave {count!r}")
    return int(count)


def _state_columns(root: etree._Element, counts: list[int]) -> dict[str, Floats] | None:
    """Each of :data:`STATE_FIELDS` for all states, or ``None`` where some state lacks a
    field (an uncertain value, a shape for a position) that others have."""
    total = sum(counts)
    columns = {name: _all_floats(root, path) for name, path in STATE_FIELDS.items()}
    for name, values in columns.items():
        optional = name in ("heading", "speed")
        if len(values) != total and not (optional and len(values) == 0):
            return None
        if len(values) == 0:
            columns[name] = np.full(total, np.nan)
    return columns


def _parsed_raws(root: etree._Element) -> tuple[list[_Raw], Counter[str]] | None:
    """Every vehicle's states parsed with lxml, five queries a file (the library's reader
    spends most of a file's reading time on them); ``None`` where the file needs the
    library's full reader."""
    obstacles = root.findall("dynamicObstacle")
    counts = [_state_count(o) for o in obstacles]
    columns = _state_columns(root, counts)
    if columns is None:
        return None
    bounds = np.cumsum(counts)[:-1]
    per_obstacle = zip(*(np.split(columns[n], bounds) for n in STATE_FIELDS), strict=True)
    raws: list[_Raw] = []
    skipped: Counter[str] = Counter()
    for element, (step, x, y, heading, speed) in zip(obstacles, per_obstacle, strict=True):
        type_name = (element.findtext("type") or "unknown").strip()
        kind, size = vehicle_type(type_name), _parsed_size(element)
        obstacle_id = element.get("id")
        if kind is None:
            skipped[type_name] += 1
        elif size is None:
            return None
        elif obstacle_id is None:
            raise ValueError("a dynamicObstacle without id")
        else:
            raws.append(_Raw(obstacle_id, *size, kind, step, np.column_stack([x, y]),
                             heading, speed))
    return raws, skipped


def _library_raws(scenario: Scenario) -> tuple[list[_Raw], Counter[str]]:
    """Every vehicle's states from the library's scenario objects."""
    raws: list[_Raw] = []
    skipped: Counter[str] = Counter()
    for obstacle in scenario.dynamic_obstacles:
        kind = vehicle_type(obstacle.obstacle_type.value)
        if kind is None:
            skipped[obstacle.obstacle_type.value] += 1
            continue
        trajectory = getattr(obstacle.prediction, "trajectory", None)
        states = [obstacle.initial_state, *(trajectory.state_list if trajectory else [])]
        raws.append(_Raw(
            str(obstacle.obstacle_id), *_size(obstacle), kind,
            np.array([s.time_step for s in states], dtype=float),
            np.array([s.position for s in states], dtype=float).reshape(-1, 2),
            np.array([getattr(s, "orientation", np.nan) for s in states], dtype=float),
            np.array([getattr(s, "velocity", np.nan) for s in states], dtype=float)))
    return raws, skipped


def _size(obstacle: DynamicObstacle) -> tuple[float, float]:
    shape = obstacle.obstacle_shape
    if hasattr(shape, "length"):
        return float(shape.length), float(shape.width)
    x0, y0, x1, y1 = shape.shapely_object.bounds
    return float(x1 - x0), float(y1 - y0)


def _fill_motion(raw: _Raw, dt: float) -> _Raw:
    """Heading and speed from the motion where the file leaves them out."""
    t = raw.step * dt
    if np.isnan(raw.heading).any():
        moving = heading_from_motion(raw.xy[:, 0], raw.xy[:, 1], t)
        raw.heading = np.where(np.isnan(raw.heading), moving, raw.heading)
    if np.isnan(raw.speed).any() and len(t) > 1:
        moved = np.hypot(np.gradient(raw.xy[:, 0], t), np.gradient(raw.xy[:, 1], t))
        raw.speed = np.where(np.isnan(raw.speed), moved, raw.speed)
    return raw


def _step_groups(lane_map: LaneMap, row: Steps, heading: Floats) -> Steps:
    """Each step's direction group: its lanelet's, held over off-map steps; a track never on
    the map takes the group its mean heading points along."""
    on_map = row >= 0
    if on_map.any():
        return hold_last(lane_map.group[np.where(on_map, row, 0)], on_map)
    mean = np.array([np.nanmean(np.cos(heading)), np.nanmean(np.sin(heading))])
    return np.full(len(row), int(np.argmax(lane_map.axes @ np.nan_to_num(mean))))


def continuous_s(xy: Floats, group: Steps, axes: Floats) -> tuple[Floats, Floats]:
    """Position along the road that never jumps: the projection on each step's direction
    group axis, except that a step into another group, or one more than
    :data:`ALONG_AXIS_DEG` off its axis (inside a junction, where a lanelet's group need not
    be the way the car drives), advances by the distance driven (the projections on two
    axes differ by up to the whole distance from the origin). Returns it and how far it is
    from the projection on the step's own axis."""
    projected = np.einsum("ij,ij->i", xy, axes[group])
    if len(xy) < 2:
        return projected, np.zeros(len(xy))
    ds = np.diff(projected)
    driven = np.hypot(*np.diff(xy, axis=0).T)
    off_axis = (driven > STILL_STEP_M) & (np.abs(ds) < np.cos(np.radians(ALONG_AXIS_DEG)) * driven)
    changed = (group[1:] != group[:-1]) | off_axis
    ds[changed] = driven[changed]
    s = projected[0] + np.concatenate([[0.0], np.cumsum(ds)])
    return s, s - projected


def lane_directions(lane_map: LaneMap, xy: Floats, row: Steps, group: Steps) -> Floats:
    """The unit direction of the lane where the car is, per step: the tangent of its
    lanelet's centre line there (its group's axis off the map)."""
    along = lane_map.axes[group].copy()
    on = row >= 0
    if on.any():
        centres, points = lane_map.centres[row[on]], shapely.points(xy[on])
        at = shapely.line_locate_point(centres, points)
        ahead = shapely.get_coordinates(shapely.line_interpolate_point(centres, at + 0.5))
        behind = shapely.get_coordinates(shapely.line_interpolate_point(centres, at - 0.5))
        tangent = ahead - behind
        norm = np.hypot(*tangent.T)
        good = norm > 0
        along[np.flatnonzero(on)[good]] = tangent[good] / norm[good, None]
    return along


def lane_lateral(xy: Floats, along: Floats) -> Floats:
    """How far the car moved across its lane since its first step (m, + to the left): each
    step's motion across the lane's direction ``along`` (:func:`lane_directions`), summed.
    A car following its lane, through a bend or a turn, or from one lanelet into the next,
    keeps its value; a lane change moves it by a lane's width."""
    normal = np.column_stack([-along[:, 1], along[:, 0]])
    moved = np.einsum("ij,ij->i", np.diff(xy, axis=0), normal[1:]) if len(xy) > 1 else []
    return np.concatenate([[0.0], np.cumsum(moved)])


def across_lane(heading: Floats, along: Floats, max_deg: float = ACROSS_LANE_DEG) -> Mask:
    """Steps where the car heads more than ``max_deg`` off its lane: it is turning into or
    out of the road, which is no lane change."""
    lane_heading = np.arctan2(along[:, 1], along[:, 0])
    off = np.abs(np.angle(np.exp(1j * (heading - lane_heading))))
    return np.nan_to_num(off, nan=0.0) > np.radians(max_deg)


def held_lane_index(index: Floats, lateral: Floats, group: Steps,
                    in_junction: Mask | None = None, window: int = 30,
                    min_move_m: float = MIN_LANE_CHANGE_M) -> Floats:
    """The lane index, changed only where the car moved at least ``min_move_m`` across the
    road within the last ``window`` steps, never inside a junction: at lanelet boundaries,
    merges, turns and across junctions (where lanes are added or shifted) the index of the
    lanelet under a car changes without the car changing lane. The window keeps a slow drift
    against a group's straight axis (a road that bends a little) from passing for a move."""
    held = index.copy()
    current, since = np.nan, 0
    inside = np.zeros(len(index), bool) if in_junction is None else in_junction
    for k in range(len(index)):
        if k and group[k] != group[k - 1] or inside[k]:
            since = k  # a new axis, or lanes that shift: lateral positions restart
        recent = lateral[max(since, k - window):k + 1]
        moved = np.isfinite(index[k]) and index[k] != current and not inside[k] \
            and float(np.max(np.abs(recent - lateral[k]))) >= min_move_m
        if not np.isfinite(current) or moved:
            current = index[k]
        held[k] = current
    return held


def _track(raw: _Raw, row: Steps, lane_map: LaneMap, dt: float) -> Track:
    lane_ids = np.array([str(lane_map.ids[r]) if r >= 0 else "" for r in row])
    index = np.where(row >= 0, lane_map.lane_index[row], np.nan)
    group = _step_groups(lane_map, row, raw.heading)
    s, off_axis = continuous_s(raw.xy, group, lane_map.axes)
    held, lateral = index, np.empty(0)
    if lane_map.urban:
        along = lane_directions(lane_map, raw.xy, row, group)
        lateral = lane_lateral(raw.xy, along)
        no_change = np.isin(lane_ids, list(lane_map.junctions)) | across_lane(raw.heading, along)
        held = held_lane_index(index, lateral, group, no_change,
                               window=int(round(LANE_CHANGE_WINDOW_S / dt)))
    # where s left the group's frame or the lane index is held against the map, the car is
    # compared with nobody
    own = (np.abs(off_axis) > SAME_FRAME_M) | (np.isfinite(index) & (held != index))
    road = np.where(own, np.char.add(f"{raw.id}/", group.astype(str)), group.astype(str))
    return Track(id=raw.id, length_m=raw.length, width_m=raw.width, vehicle_type=raw.kind,
                 t=raw.step * dt, x=raw.xy[:, 0], y=raw.xy[:, 1], heading=raw.heading,
                 speed=raw.speed, s=s, lane=lane_ids, lane_index=held, road=road,
                 lateral=lateral)


def _tracks(raws: list[_Raw], lane_map: LaneMap, dt: float, warnings: list[str]
            ) -> list[Track]:
    """Tracks of the vehicles seen in two steps or more, their lanes found in one query."""
    raws = [_fill_motion(r, dt) for r in raws if len(r.step) >= 2]
    if not raws:
        return []
    rows = lane_map.locate(np.concatenate([r.xy for r in raws]),
                           np.concatenate([r.heading for r in raws]))
    bounds = np.cumsum([len(r.step) for r in raws])[:-1]
    tracks = [_track(raw, row, lane_map, dt)
              for raw, row in zip(raws, np.split(rows, bounds), strict=True)]
    off = int((rows < 0).sum())
    if off:
        warnings.append(f"{off} of {len(rows)} positions are on no lanelet (lane unknown)")
    return tracks


# --- traffic lights -------------------------------------------------------------------------

def _stop_point(lanelet: Lanelet) -> Floats:
    line = lanelet.stop_line
    if line is not None and line.start is not None and line.end is not None:
        return (np.asarray(line.start, float) + np.asarray(line.end, float)) / 2
    return np.asarray(lanelet.center_vertices[-1], float)


def _stop_line(lanelet: Lanelet) -> tuple[str, float, float, float, float]:
    """The lanelet's stop line (its end across the lane where it has none)."""
    line = lanelet.stop_line
    if line is not None and line.start is not None and line.end is not None:
        ends = np.asarray(line.start, float), np.asarray(line.end, float)
    else:
        ends = np.asarray(lanelet.left_vertices[-1], float), \
            np.asarray(lanelet.right_vertices[-1], float)
    centre = np.asarray(lanelet.center_vertices, float)
    travel = centre[-1] - centre[-2]
    across = ends[1] - ends[0]
    if travel[0] * across[1] - travel[1] * across[0] > 0:  # make it run left to right
        ends = ends[1], ends[0]
    x0, y0, x1, y1 = (round(float(v), 4) for v in (*ends[0], *ends[1]))
    return str(lanelet.lanelet_id), x0, y0, x1, y1


def _movements(light: CrLight) -> str:
    direction = getattr(light, "direction", None)
    return str(getattr(direction, "value", direction) or "all")


def junction_lanelets(network: LaneletNetwork, lane_map: LaneMap) -> frozenset[str]:
    """Lanelets inside junctions: those an intersection's incomings lead into, and those
    crossing a lanelet that runs another way (more than 30 deg apart, 1 m^2 shared)."""
    inside = {str(i) for it in network.intersections for inc in it.incomings
              for i in (*inc.outgoing_right, *inc.outgoing_straight, *inc.outgoing_left)}
    shrunk = shapely.buffer(lane_map.polygons, -0.3)
    a, b = shapely.STRtree(shrunk).query(shrunk, predicate="intersects")
    directions = np.array([_direction(np.asarray(c.coords)) for c in lane_map.centres])
    for i, j in zip(a.tolist(), b.tolist(), strict=True):
        if i != j and abs(directions[i] @ directions[j]) < np.cos(np.radians(30)) \
                and shapely.area(shapely.intersection(shrunk[i], shrunk[j])) > 1.0:
            inside.add(str(lane_map.ids[i]))
    return frozenset(inside)


def light_phases(light: CrLight, last_step: int, dt: float) -> tuple[LightPhase, ...]:
    """The light's colours over steps 0..last_step as runs of one colour (red and redYellow
    make one red run); an inactive run is left out."""
    cycle = light.traffic_light_cycle
    colours = [COLOURS.get(cycle.get_state_at_time_step(step)) for step in range(last_step + 1)]
    phases, start = [], 0
    for step in range(1, last_step + 2):
        if step <= last_step and colours[step] == colours[start]:
            continue
        colour = colours[start]
        if colour is not None:
            phases.append(LightPhase(round(start * dt, 9), round(min(step, last_step) * dt, 9),
                                  colour))
        start = step
    return tuple(phases)


def _lights(network: LaneletNetwork, lane_map: LaneMap, last_step: int, dt: float,
            warnings: list[str]) -> list[TrafficLight]:
    lights = []
    row_of = {lanelet_id: row for row, lanelet_id in enumerate(lane_map.ids)}
    for light in network.traffic_lights:
        lanelets = [ll for ll in network.lanelets if light.traffic_light_id in ll.traffic_lights]
        cycle = light.traffic_light_cycle
        if not light.active or cycle is None or not cycle.cycle_elements:
            warnings.append(f"traffic light {light.traffic_light_id} has no active cycle")
            phases: tuple[LightPhase, ...] = ()
        else:
            phases = light_phases(light, last_step, dt)
        stop_s = None
        if lanelets:
            rows = np.array([row_of[ll.lanelet_id] for ll in lanelets])
            points = np.array([_stop_point(ll) for ll in lanelets])
            stop_s = float(np.mean(lane_map.s(points, lane_map.group[rows])))
        lights.append(TrafficLight(id=str(light.traffic_light_id),
                                   lanes=tuple(str(ll.lanelet_id) for ll in lanelets),
                                   stop_line_s=stop_s, phases=phases,
                                   direction=_movements(light),
                                   stop_lines=tuple(_stop_line(ll) for ll in lanelets)))
    return lights


def _number(element: etree._Element, path: str) -> float | None:
    text = element.findtext(path)
    try:
        return float(text) if text is not None else None
    except ValueError:
        return None


def _planned_vehicle(problem: etree._Element, last_step: int, dt: float) -> _Raw | None:
    """The vehicle CommonRoad took out of the file as its planning problem's ego, along the
    path its initial state and goal imply: from the start to the goal area's centre (at the
    middle of the goal's time interval) with a constant acceleration, else at its start
    speed along its heading. Approximate, but it says where a gap in the traffic is."""
    start = problem.find("initialState")
    if start is None:
        return None
    x, y = _number(start, "position/point/x"), _number(start, "position/point/y")
    speed, heading = _number(start, "velocity/exact"), _number(start, "orientation/exact")
    step0 = _number(start, "time/exact") or 0.0
    if x is None or y is None or speed is None or heading is None:
        return None
    goal = _goal(problem)
    steps = np.arange(step0, last_step + 1, dtype=float)
    t = (steps - step0) * dt
    direction, accel = np.array([np.cos(heading), np.sin(heading)]), 0.0
    if goal is not None and goal[2] > step0:
        goal_x, goal_y, goal_step = goal
        towards = np.array([goal_x - x, goal_y - y])
        span_s = (goal_step - step0) * dt
        direction = towards / max(float(np.hypot(*towards)), 1e-9)
        accel = 2 * (float(np.hypot(*towards)) - speed * span_s) / span_s ** 2
    along = speed * t + accel * t ** 2 / 2
    return _Raw(problem.get("id", "planned"), 4.5, 1.8, "car", steps,
                np.array([x, y]) + along[:, None] * direction, np.full(len(steps), heading),
                np.clip(speed + accel * t, 0.0, None))


def _goal(problem: etree._Element) -> tuple[float, float, float] | None:
    """The centre of the planning problem's goal area and the middle of its time interval (a
    step), where the file gives all of them."""
    goal = problem.find("goalState")
    if goal is None:
        return None
    x = _number(goal, "position/rectangle/center/x")
    y = _number(goal, "position/rectangle/center/y")
    first, last = _number(goal, "time/intervalStart"), _number(goal, "time/intervalEnd")
    if x is None or y is None or first is None or last is None:
        return None
    return x, y, (first + last) / 2


def _network(root: etree._Element) -> LaneletNetwork:
    """The lanelet network and traffic lights, read by the library from the file with its
    obstacles and planning problems taken out of ``root`` (the library would parse those)."""
    for child in root.findall("dynamicObstacle") + root.findall("planningProblem"):
        root.remove(child)
    with _quiet_library():
        return CommonRoadFileReader(etree.tostring(root)).open_lanelet_network()


def read(path: Path) -> Recording:
    """The scenario's vehicles and traffic lights."""
    path = Path(path)
    root = etree.parse(str(path)).getroot()
    dt = float(root.get("timeStepSize", "0.1"))
    parsed = _parsed_raws(root)
    if parsed is None:
        with _quiet_library():
            scenario, _ = CommonRoadFileReader(str(path)).open()
        parsed = _library_raws(scenario)
    raws, skipped = parsed
    problems = root.findall("planningProblem")
    network = _network(root)
    warnings = skipped_warning(skipped)
    lane_map = LaneMap.of(network)
    junctions = junction_lanelets(network, lane_map)
    lane_map.urban = bool(junctions or network.traffic_lights)
    lane_map.junctions = junctions
    tracks = _tracks(raws, lane_map, dt, warnings)
    last_step = int(max((t.t[-1] for t in tracks), default=0.0) / dt + 0.5)
    lights = _lights(network, lane_map, last_step, dt, warnings)
    planned = [r for r in (_planned_vehicle(p, last_step, dt) for p in problems) if r is not None]
    removed = _tracks(planned, lane_map, dt, []) if tracks else []
    return Recording(source=str(path), dt=dt, tracks=sort_tracks(tracks), lights=lights,
                     reader=NAME, warnings=[f"{path.name}: {w}" for w in warnings],
                     junction_lanes=junctions,
                     removed=removed)

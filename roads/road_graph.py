"""The road graph of a map: roads as a graph of their ends, with sampled reference lines.

Where the lane graph (``road_network``) follows one lane, this graph answers for whole roads,
which is what cutting a map needs: a road end ``(road id, 0 start | 1 end)`` *touches* the
road ends it meets through a road link or a junction connection. On it:

- :meth:`RoadGraph.reach` - the roads entered within a distance, taking at every junction and
  from every lane that arrives there the connection heading straightest on (ties kept; with
  ``routed`` also the first one listed), and the road ends driven through;
- :meth:`RoadGraph.routes` - the roads on every forward route into a set of goal roads at
  most a given factor longer than the shortest;
- :meth:`RoadGraph.roads_near` - the roads passing near a point, from reference lines sampled
  every ``SAMPLE_STEP_M``.

Distances are the fewest metres a car drives: a road's length divided by its ``s_rate``, the
most ``s`` a car on one of its drivable lanes covers per metre (more than 1 on the inside of
curves).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np

from scenweave.roads.bundled import road_network
from scenweave.roads.lanes import normalize_angle
from scenweave.roads.opendrive import DRIVABLE_LANE_TYPES, OpenDriveMap, Road, RoadLink

#: ``s`` per metre driven is bounded as if no lane came closer to a curve's centre than
#: this share of its radius
MAX_BEND = 0.8
#: the reference lines are sampled this densely for the look-ups by position (m)
SAMPLE_STEP_M = 2.0
#: junction connections this close to the straightest are all taken (rad)
TIE_TOLERANCE = math.radians(3)

#: one end of a road: ``(road id, 0 start | 1 end)``
RoadEnd = tuple[str, int]
#: a start point: road, ``s`` and the directions along ``s`` it may move (+1, -1)
Start = tuple[str, float, tuple[int, ...]]


@dataclass
class RoadGraph:
    """One map's roads as a graph of road ends, with sampled reference lines."""

    #: road id -> the road, in file order
    roads: dict[str, Road]
    lengths: dict[str, float]
    #: road end -> the road ends it touches
    touches: dict[RoadEnd, set[RoadEnd]]
    #: road id -> (has drivable lanes along s, has drivable lanes against s)
    drives: dict[str, tuple[bool, bool]]
    #: signal id -> road id holding the ``<signal>``
    signal_roads: dict[str, str]
    #: whether every road id is a number
    numeric_ids: bool
    #: road end -> the road ends it continues into through a road link (not a junction)
    road_links: dict[RoadEnd, list[RoadEnd]]
    #: road end at a junction -> incoming lane id -> (connecting road, end entered) options
    lane_options: dict[RoadEnd, dict[int, list[RoadEnd]]]
    #: road end -> the drivable lanes whose traffic drives towards it
    toward: dict[RoadEnd, set[int]]
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
    #: (road, end, routed) -> where traffic leaving there goes (``choices``, computed once)
    _choices: dict[tuple[str, int, bool], list[RoadEnd]] = field(default_factory=dict,
                                                                 repr=False)

    @property
    def total_length(self) -> float:
        """Metres of road on the map (reference lines)."""
        return sum(self.lengths.values())

    # --- positions ----------------------------------------------------------------------------
    def roads_near(self, x: float, y: float, radius: float) -> dict[str, tuple[float, float]]:
        """Each road passing within ``radius`` of ``(x, y)`` (and always the nearest):
        road id -> ``(s, heading)`` of its sample nearest to the point, nearest road first."""
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
        row = self._sample_row(road, s)
        return None if row is None else float(self.sample_hdg[row])

    def side_of(self, road: str, s: float, x: float, y: float) -> float:
        """How far ``(x, y)`` lies left of ``road``'s reference line (negative: right), from
        the sample nearest ``s``."""
        row = self._sample_row(road, s)
        if row is None:
            raise KeyError(f"road {road} has no reference line samples")
        heading = self.sample_hdg[row]
        px, py = self.sample_xy[row]
        return float(-math.sin(heading) * (x - px) + math.cos(heading) * (y - py))

    def _sample_row(self, road: str, s: float) -> int | None:
        if road not in self.roads:
            return None
        rows = np.flatnonzero(self.sample_road == self.road_order.index(road))
        if not len(rows):
            return None
        return int(rows[np.argmin(np.abs(self.sample_s[rows] - s))])

    # --- driving ------------------------------------------------------------------------------
    def enters(self, road: str, end: int) -> bool:
        """Whether traffic may enter ``road`` at ``end`` (it has drivable lanes leading away)."""
        along, against = self.drives[road]
        return along if end == 0 else against

    def driven(self, road: str) -> float:
        """The fewest metres a car drives along the whole of ``road``."""
        return self.lengths[road] / self.s_rate.get(road, 1.0)

    def leaving(self, starts: Iterable[Start]) -> list[tuple[float, str, int]]:
        """The road ends the starts drive to: ``(metres driven at least, road, end)``."""
        found = []
        for road, s, directions in starts:
            rate = self.s_rate.get(road, 1.0)
            for direction in directions:
                found.append(((self.lengths[road] - s) / rate, road, 1) if direction > 0 else
                             (s / rate, road, 0))
        return found

    def choices(self, road: str, end: int, routed: bool = False) -> list[RoadEnd]:
        """Where traffic leaving ``road`` at ``end`` goes: the linked road, or per incoming
        lane the junction connection whose exit heading is closest to the road's heading,
        with ``routed`` also the lane's first connection."""
        key = (road, end, routed)
        if key in self._choices:
            return self._choices[key]
        if (road, end) in self.road_links:
            chosen = sorted(set(self.road_links[(road, end)]))
        else:
            options = self.lane_options.get((road, end), {})
            lanes = self.toward[(road, end)] & options.keys() or set(options)
            heading_in = self.end_headings[road][end] + (0.0 if end == 1 else math.pi)
            found: set[RoadEnd] = set()
            for lane in lanes:
                turns = [(abs(normalize_angle(self._exit_heading(c, c_end) - heading_in)),
                          (c, c_end)) for c, c_end in options[lane]]
                best = min(turn for turn, _ in turns)
                found.update(option for turn, option in turns if turn <= best + TIE_TOLERANCE)
                if routed:
                    found.add(options[lane][0])
            chosen = sorted(found)
        self._choices[key] = chosen
        return chosen

    def _exit_heading(self, road: str, entered: int) -> float:
        start, end = self.end_headings.get(road, (0.0, 0.0))
        return end if entered == 0 else start + math.pi

    def reach(self, starts: list[Start], reach_m: float, routed: bool = False
              ) -> tuple[set[str], set[RoadEnd]]:
        """The roads entered within ``reach_m`` of the starts taking, at every road end, what
        :meth:`choices` takes; and the road ends driven through."""
        roads = {road for road, _, _ in starts}
        queue = self.leaving(starts)
        heapq.heapify(queue)
        done: set[RoadEnd] = set()
        while queue:
            d, road, end = heapq.heappop(queue)
            if (road, end) in done or d > reach_m:
                continue
            done.add((road, end))
            for other, other_end in self.choices(road, end, routed):
                roads.add(other)
                heapq.heappush(queue, (d + self.driven(other), other, 1 - other_end))
        return roads, done

    def forward(self, starts: list[Start]) -> dict[RoadEnd, float]:
        """Metres driven from the nearest start until entering each road at each end
        (Dijkstra over road ends, forward only, every junction connection, into a road only
        where it has drivable lanes leading away)."""
        entered: dict[RoadEnd, float] = {}
        queue = self.leaving(starts)
        heapq.heapify(queue)
        done: set[RoadEnd] = set()
        while queue:
            d, road, end = heapq.heappop(queue)
            if (road, end) in done:
                continue
            done.add((road, end))
            for other, other_end in self.touches[(road, end)]:
                if not self.enters(other, other_end):
                    continue
                if d < entered.get((other, other_end), math.inf):
                    entered[(other, other_end)] = d
                    heapq.heappush(queue, (d + self.driven(other), other, 1 - other_end))
        return entered

    def routes(self, starts: list[Start], goal: set[str], slack: float,
               margin_m: float) -> tuple[set[str], float]:
        """The roads on every forward route from the starts into a ``goal`` road at most
        ``slack`` times (plus ``margin_m``) longer than the shortest, and the shortest's
        length (0 when a start is on a goal road, infinite when none is reached)."""
        if any(road in goal for road, _, _ in starts):
            return {road for road, _, _ in starts}, 0.0
        ahead = self.forward(starts)
        shortest = min((d for (road, _), d in ahead.items() if road in goal), default=math.inf)
        if not math.isfinite(shortest):
            return set(), shortest
        budget = slack * shortest + margin_m
        # metres from entering a road at an end until entering a goal road (Dijkstra backwards)
        behind: dict[RoadEnd, float] = {}
        queue = [(0.0, road, end) for road in goal for end in (0, 1) if self.enters(road, end)]
        heapq.heapify(queue)
        while queue:
            d, road, end = heapq.heappop(queue)
            if (road, end) in behind or d > budget:
                continue
            behind[(road, end)] = d
            for before, before_end in self.touches[(road, end)]:
                node = (before, 1 - before_end)  # entered at the other end, left at before_end
                if self.enters(*node) and node not in behind:
                    heapq.heappush(queue, (d + self.driven(before), *node))
        found = {road for road, _, _ in starts}
        found.update(road for (road, end), d in ahead.items()
                     if d + behind.get((road, end), math.inf) <= budget)
        return found, shortest


def road_graph(map_path: str | Path) -> RoadGraph:
    """The road graph of ``map_path``, built once per process and file version."""
    path = Path(map_path).resolve()
    stat = path.stat()
    return _graph(path, stat.st_mtime_ns, stat.st_size)


@cache
def _graph(path: Path, mtime_ns: int, size: int) -> RoadGraph:
    return build_road_graph(road_network(path).map)


def build_road_graph(odr: OpenDriveMap) -> RoadGraph:
    """The road graph of an OpenDRIVE map."""
    roads = dict(odr.roads)
    touches: dict[RoadEnd, set[RoadEnd]] = {(rid, end): set() for rid in roads for end in (0, 1)}
    road_links: dict[RoadEnd, list[RoadEnd]] = {}
    lane_options: dict[RoadEnd, dict[int, list[RoadEnd]]] = {}
    for rid, road in roads.items():
        for end, link in ((0, road.predecessor), (1, road.successor)):
            if link is None:
                continue
            if link.element_type == "junction":
                options = lane_options.setdefault((rid, end), {})
                for connecting, other_end, lanes in _connections_from(odr, rid, link):
                    _touch(touches, (rid, end), (connecting, other_end))
                    for lane in lanes:
                        options.setdefault(lane, []).append((connecting, other_end))
                continue
            for other_end in _contact_ends(link.contact_point):
                _touch(touches, (rid, end), (link.element_id, other_end))
                if link.element_id in roads:
                    road_links.setdefault((rid, end), []).append((link.element_id, other_end))
    incoming: dict[str, set[str]] = {}
    for junction in odr.junctions.values():
        for connection in junction.connections:
            incoming.setdefault(connection.connecting_road, set()).add(connection.incoming_road)
    graph = RoadGraph(
        roads=roads, lengths={rid: road.length for rid, road in roads.items()},
        touches=touches, drives={rid: _drive_directions(road) for rid, road in roads.items()},
        signal_roads={signal.id: rid for rid, road in roads.items() for signal in road.signals},
        numeric_ids=all(rid.isdigit() for rid in roads), road_links=road_links,
        lane_options=lane_options,
        toward={(rid, end): _lanes_toward(road, end) for rid, road in roads.items()
                for end in (0, 1)},
        incoming=incoming)
    _sample_reference_lines(graph)
    return graph


def _connections_from(odr: OpenDriveMap, rid: str, link: RoadLink
                      ) -> Iterator[tuple[str, int, list[int]]]:
    """``(connecting road, end entered, incoming lane ids)`` of each connection of the
    junction ``link`` names that road ``rid`` comes in on."""
    junction = odr.junctions.get(link.element_id)
    for connection in junction.connections if junction is not None else ():
        if connection.incoming_road == rid:
            lanes = [lane for lane, _ in connection.lane_links]
            for other_end in _contact_ends(connection.contact_point):
                yield connection.connecting_road, other_end, lanes


def _touch(touches: dict[RoadEnd, set[RoadEnd]], a: RoadEnd, b: RoadEnd) -> None:
    if a in touches and b in touches:
        touches[a].add(b)
        touches[b].add(a)


def _contact_ends(contact: str | None) -> tuple[int, ...]:
    return {"start": (0,), "end": (1,)}.get(contact or "", (0, 1))


def _drive_directions(road: Road) -> tuple[bool, bool]:
    along = against = False
    for section in road.sections:
        for lane_id, lane in section.lanes.items():
            if lane_id == 0 or lane.type not in DRIVABLE_LANE_TYPES:
                continue
            if lane.type == "bidirectional":
                along = against = True
            elif lane_id < 0:
                along = True
            else:
                against = True
    return along, against


def _lanes_toward(road: Road, end: int) -> set[int]:
    """The drivable lanes of the lane section at ``end`` whose traffic drives towards it."""
    if not road.sections:
        return set()
    section = road.sections[-1] if end == 1 else road.sections[0]
    side = -1 if end == 1 else 1
    return {lane_id for lane_id, lane in section.lanes.items()
            if lane_id * side > 0 and lane.type in DRIVABLE_LANE_TYPES}


def _s_rate(road: Road, s: np.ndarray, curvature: np.ndarray) -> float:
    """The most ``s`` a car on a drivable lane of ``road`` covers per metre driven: it moves
    ``1 / (1 - curvature * t)`` of ``s`` per metre at lateral offset ``t``, which is largest at
    the outer border of the outermost drivable lane on the inside of a curve."""
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


def _sample_reference_lines(graph: RoadGraph) -> None:
    xy, hdg, ss, which = [], [], [], []
    for order, (rid, road) in enumerate(graph.roads.items()):
        graph.road_order.append(rid)
        length = graph.lengths[rid]
        if length <= 0:
            continue
        s = np.linspace(0.0, length, max(2, math.ceil(length / SAMPLE_STEP_M) + 1))
        pose = road.plan_view.pose(s)
        graph.end_headings[rid] = (float(pose.hdg[0]), float(pose.hdg[-1]))
        graph.s_rate[rid] = _s_rate(road, s, pose.curvature)
        xy.append(np.column_stack([pose.x, pose.y]))
        hdg.append(pose.hdg)
        ss.append(s)
        which.append(np.full(len(s), order))
    if xy:
        graph.sample_xy = np.concatenate(xy)
        graph.sample_hdg = np.concatenate(hdg)
        graph.sample_s = np.concatenate(ss)
        graph.sample_road = np.concatenate(which)

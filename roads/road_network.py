"""The lane graph of a road network: which lane follows which, and walks along lanes.

A lane of one lane section is a node ``LaneKey(road_id, section, lane_id)``. Its successors
are the lanes traffic enters when it leaves the node in its driving direction: the next lane
section of the same road, the linked road, or every connecting road of a junction that the
lane feeds. Walks follow the straightest successor, so a distance "along the lane" crosses
road boundaries the way a car keeping its lane would.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple, TypeVar, cast

import numpy as np

from scenweave.roads.errors import LaneEndsError, OpenDriveError
from scenweave.roads.lanes import (
    WorldPose,
    driving_direction,
    lane_border_offsets,
    lane_distance,
    lane_pose,
    lane_width,
    normalize_angle,
    point_at,
    s_after_distance,
    section_samples,
)
from scenweave.roads.opendrive import OpenDriveMap, Road, RoadLink
from scenweave.roads.plan_view import ReferencePose

T = TypeVar("T")

#: a neighbouring lane narrower than this somewhere in its section is not usable for a manoeuvre
MIN_USABLE_WIDTH_M = 2.5
#: heading change (rad) beyond which a junction movement counts as a turn
TURN_THRESHOLD_RAD = math.radians(30)


class LaneKey(NamedTuple):
    """One lane of one lane section."""

    road_id: str
    section: int
    lane_id: int


class LanePoint(NamedTuple):
    """A lane position: road, lane and ``s`` along the road's reference line."""

    road_id: str
    lane_id: int
    s: float


@dataclass(frozen=True)
class BorderLine:
    """One border of a drivable lane section as a polyline in the map's frame, for drawing
    (the viewer's lanes, the replay figure's map)."""

    #: (n, 2) points ``x, y``
    points: np.ndarray
    in_junction: bool

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1) of the line."""
        return (float(self.points[:, 0].min()), float(self.points[:, 0].max()),
                float(self.points[:, 1].min()), float(self.points[:, 1].max()))


@dataclass(frozen=True)
class Segment:
    """A stretch of one lane driven by a walk: from ``s_from`` to ``s_to``, ``length`` metres."""

    key: LaneKey
    s_from: float
    s_to: float
    length: float


class RoadNetwork:
    """An OpenDRIVE map with its lane graph."""

    def __init__(self, odr: OpenDriveMap) -> None:
        self.map = odr
        #: per-network memo of derived facts (lane lengths, turns, neighbours, approaches)
        self.memo: dict[tuple[str, Hashable], object] = {}
        self._next: dict[LaneKey, list[tuple[LaneKey, float]]] = {}
        self._previous: dict[LaneKey, list[tuple[LaneKey, float]]] = {}
        for key in self.drivable_lanes():
            self._next[key] = sorted(self._successors_of(key), key=_order)
        for key, targets in self._next.items():
            for target, _ in targets:
                self._previous.setdefault(target, []).append((key, self.exit_s(key)))
        for targets in self._previous.values():
            targets.sort(key=_order)

    # --- lookup -------------------------------------------------------------------------------
    def road(self, road_id: str | int) -> Road:
        """The road with this id."""
        road = self.map.roads.get(str(road_id))
        if road is None:
            raise OpenDriveError(f"{self.map.name}: no road with id {road_id}")
        return road

    def drivable_lanes(self) -> Iterator[LaneKey]:
        """Every drivable lane of every lane section, in file order."""
        for road in self.map.roads.values():
            for index, section in enumerate(road.sections):
                for lane_id, lane in sorted(section.lanes.items()):
                    if lane_id != 0 and lane.drivable:
                        yield LaneKey(road.id, index, lane_id)

    def border_lines(self, step_m: float = 2.0) -> list[BorderLine]:
        """Both borders of every drivable lane section, sampled about ``step_m`` apart along
        the road, in file order."""
        found = []
        sampled: dict[tuple[str, int], tuple[np.ndarray, ReferencePose]] = {}
        for key in self.drivable_lanes():
            road = self.road(key.road_id)
            section = road.sections[key.section]
            if (key.road_id, key.section) not in sampled:  # the lanes of a section share it
                s = section_samples(section, step_m)
                sampled[key.road_id, key.section] = s, road.plan_view.pose(s)
            s, pose = sampled[key.road_id, key.section]
            for offsets in lane_border_offsets(road, section, key.lane_id, s):
                t = offsets[0]
                points = np.column_stack([pose.x - t * np.sin(pose.hdg),
                                          pose.y + t * np.cos(pose.hdg)])
                found.append(BorderLine(points, bool(road.in_junction)))
        return found

    def key_at(self, road_id: str | int, lane_id: int, s: float) -> LaneKey:
        """The lane-section node holding ``s`` on ``lane_id`` of the road."""
        road = self.road(road_id)
        if not -1e-6 <= s <= road.length + 1e-6:
            raise OpenDriveError(
                f"road {road.id}: s={s:g} is outside the road (0..{road.length:g})")
        index = road.section_index(s, moving_forward=lane_id < 0)
        if lane_id not in road.sections[index].lanes or lane_id == 0:
            raise OpenDriveError(f"road {road.id} has no lane {lane_id} at s={s:g}")
        return LaneKey(road.id, index, lane_id)

    def exit_s(self, key: LaneKey) -> float:
        """The ``s`` where traffic leaves this lane section."""
        section = self.road(key.road_id).sections[key.section]
        return section.s_end if driving_direction(key.lane_id) > 0 else section.s_start

    def entry_s(self, key: LaneKey) -> float:
        """The ``s`` where traffic enters this lane section."""
        section = self.road(key.road_id).sections[key.section]
        return section.s_start if driving_direction(key.lane_id) > 0 else section.s_end

    def successors(self, key: LaneKey) -> list[LaneKey]:
        """Lanes traffic may enter on leaving ``key`` (sorted by road, section, lane)."""
        return [target for target, _ in self._next.get(key, [])]

    def predecessors(self, key: LaneKey) -> list[LaneKey]:
        """Lanes from which traffic enters ``key``."""
        return [source for source, _ in self._previous.get(key, [])]

    # --- geometry -----------------------------------------------------------------------------
    def lane_to_world(self, road_id: str | int, lane_id: int, s: float,
                      offset: float = 0.0) -> WorldPose:
        """World pose (OpenDRIVE = OpenSCENARIO frame) of a lane position."""
        self.key_at(road_id, lane_id, s)
        return lane_pose(self.road(road_id), lane_id, s, offset)

    def key_to_world(self, key: LaneKey, s: float) -> WorldPose:
        """World pose of the centre of lane section ``key`` at ``s`` (may be its boundary)."""
        return lane_pose(self.road(key.road_id), key.lane_id, s, section_index=key.section)

    def turn_angle(self, key: LaneKey) -> float:
        """Heading change (rad, left positive) traffic makes while driving this lane section."""
        def turn() -> float:
            road = self.road(key.road_id)
            start = point_at(road, self.entry_s(key), 0.0, key.lane_id).h
            end = point_at(road, self.exit_s(key), 0.0, key.lane_id).h
            return normalize_angle(end - start)

        return self.remembered("turn", key, turn)

    def remembered(self, kind: str, key: Hashable, compute: Callable[[], T]) -> T:
        """``compute()``'s answer for ``key``, computed once per network and ``kind``."""
        memo_key = (kind, key)
        if memo_key not in self.memo:
            self.memo[memo_key] = compute()
        return cast(T, self.memo[memo_key])  # one kind, one type: what compute() gave

    def segment_length(self, key: LaneKey, s_from: float, s_to: float) -> float:
        """Distance driven along the lane between two ``s`` of its section (whole ones cached)."""
        road = self.road(key.road_id)
        section = road.sections[key.section]
        if {s_from, s_to} != {section.s_start, section.s_end}:
            return lane_distance(road, section, key.lane_id, s_from, s_to)
        return self.remembered(
            "length", key, lambda: lane_distance(road, section, key.lane_id, s_from, s_to))

    def movement(self, key: LaneKey) -> str:
        """``straight``, ``left`` or ``right``: what driving this (junction) lane amounts to."""
        angle = self.turn_angle(key)
        if angle > TURN_THRESHOLD_RAD:
            return "left"
        return "right" if angle < -TURN_THRESHOLD_RAD else "straight"

    def neighbour(self, key: LaneKey, side: str) -> LaneKey | None:
        """The same-direction drivable lane on ``side`` (``left``/``right`` as the driver sees it).

        ``None`` when there is none, or when it is narrower than ``MIN_USABLE_WIDTH_M``
        somewhere in the section (a lane that opens or closes there).
        """
        return self.remembered("neighbour", (key, side), lambda: self._find_neighbour(key, side))

    def _find_neighbour(self, key: LaneKey, side: str) -> LaneKey | None:
        step = {"left": 1, "right": -1}[side] * (1 if key.lane_id < 0 else -1)
        lane_id = key.lane_id + step
        road = self.road(key.road_id)
        section = road.sections[key.section]
        lane = section.lanes.get(lane_id)
        if lane_id == 0 or (lane_id > 0) != (key.lane_id > 0) or lane is None or not lane.drivable:
            return None
        samples = np.linspace(section.s_start, section.s_end, 21)
        if float(lane_width(road, section, lane_id, samples).min()) < MIN_USABLE_WIDTH_M:
            return None
        return LaneKey(key.road_id, key.section, lane_id)

    def oncoming_lanes(self, key: LaneKey) -> list[LaneKey]:
        """The drivable lanes whose traffic comes the other way, nearest the centre first."""
        section = self.road(key.road_id).sections[key.section]
        sign = 1 if key.lane_id < 0 else -1
        return [LaneKey(key.road_id, key.section, lane_id)
                for lane_id in sorted((i for i in section.lanes if i * sign > 0), key=abs)
                if section.lanes[lane_id].drivable]

    # --- walks --------------------------------------------------------------------------------
    def walk(self, road_id: str | int, lane_id: int, s: float,
             forward: bool = True) -> Iterator[Segment]:
        """Segments driven from a lane position, with (``forward``) or against traffic.

        At every branching the straightest continuation is taken. The walk ends where the
        drivable network ends; on a loop it never ends, so callers stop it.
        """
        self.key_at(road_id, lane_id, s)
        road = self.road(road_id)
        along_s = (driving_direction(lane_id) > 0) == forward
        key = LaneKey(road.id, road.section_index(s, moving_forward=along_s), lane_id)
        while True:
            end = self.exit_s(key) if forward else self.entry_s(key)
            yield Segment(key, s, end, self.segment_length(key, s, end))
            options = self._next.get(key, []) if forward else self._previous.get(key, [])
            if not options:
                return
            key, s = min(options, key=lambda option: (abs(self.turn_angle(option[0])),
                                                      _order(option)))

    def advance(self, road_id: str | int, lane_id: int, s: float, distance: float) -> LanePoint:
        """The lane position ``distance`` metres along the lane (negative: behind)."""
        forward = distance >= 0
        remaining = abs(distance)
        travelled = 0.0
        for segment in self.walk(road_id, lane_id, s, forward):
            if remaining <= segment.length + 1e-9:
                key = segment.key
                road = self.road(key.road_id)
                direction = 1 if segment.s_to >= segment.s_from else -1
                s_new = s_after_distance(road, road.sections[key.section], key.lane_id,
                                         segment.s_from, remaining, direction)
                return LanePoint(key.road_id, key.lane_id, s_new)
            remaining -= segment.length
            travelled += segment.length
        raise LaneEndsError(
            f"lane {lane_id} of road {road_id} at s={s:g}: the drivable lane ends "
            f"{travelled:.1f} m {'ahead' if forward else 'behind'}, {abs(distance):.1f} m needed")

    def distance_between(self, start: LanePoint, end: LanePoint, cap: float) -> float | None:
        """Signed metres along the lane from ``start`` to ``end`` (negative: ``end`` is behind).

        Follows the walk of :meth:`walk` (straightest continuation) ahead, then behind, up to
        ``cap`` metres each way; ``None`` when ``end`` is not on that lane within reach.
        """
        here = self.key_at(start.road_id, start.lane_id, start.s)
        if (here.road_id, here.lane_id) == (str(end.road_id), end.lane_id) \
                and self._in_section(here, end.s):  # the common case: one integration
            ahead = (end.s >= start.s) == (driving_direction(start.lane_id) > 0)
            length = self.segment_length(here, start.s, end.s)
            if length > cap:
                return None
            return length if ahead or length == 0.0 else -length
        # the car behind drives the straightest way on, as players do, so walking forward from
        # each end finds the way driven; walking back from the car ahead may take another
        # branch at a junction and, on a map with loops (Town06), come round the long way
        found = [d for d in (self._walked_to(start, end, True, cap),
                             _negated(self._walked_to(end, start, True, cap))) if d is not None]
        if found:
            return min(found, key=abs)
        return _negated(self._walked_to(start, end, False, cap))

    def _walked_to(self, start: LanePoint, end: LanePoint, forward: bool,
                   cap: float) -> float | None:
        """Metres walked from ``start`` (ahead or behind) until ``end``, None beyond ``cap``."""
        try:
            walk = self.walk(start.road_id, start.lane_id, start.s, forward)
            travelled = 0.0
            for segment in walk:
                low, high = sorted((segment.s_from, segment.s_to))
                key = segment.key
                if (key.road_id, key.lane_id) == (str(end.road_id), end.lane_id) \
                        and low - 1e-6 <= end.s <= high + 1e-6:
                    return travelled + self.segment_length(key, segment.s_from, end.s)
                travelled += segment.length
                if travelled > cap:
                    break
        except OpenDriveError:  # ``end`` named as a start is not a lane position
            return None
        return None

    def _in_section(self, key: LaneKey, s: float) -> bool:
        section = self.road(key.road_id).sections[key.section]
        return section.s_start - 1e-6 <= s <= section.s_end + 1e-6

    def drivable_length(self, road_id: str | int, lane_id: int, s: float, forward: bool,
                        cap: float) -> float:
        """Metres drivable from a lane position (ahead or behind), at most ``cap``."""
        total = 0.0
        for segment in self.walk(road_id, lane_id, s, forward):
            total += segment.length
            if total >= cap:
                return cap
        return total

    # --- construction -------------------------------------------------------------------------
    def _successors_of(self, key: LaneKey) -> Iterator[tuple[LaneKey, float]]:
        road = self.road(key.road_id)
        lane = road.sections[key.section].lanes[key.lane_id]
        ahead = driving_direction(key.lane_id) > 0
        next_section = key.section + (1 if ahead else -1)
        linked_lane = lane.successor if ahead else lane.predecessor
        if 0 <= next_section < len(road.sections):
            if linked_lane is not None:
                target = LaneKey(road.id, next_section, linked_lane)
                if self._drivable(target):
                    yield target, self.entry_s(target)
            return
        link = road.successor if ahead else road.predecessor
        if link is None:
            return
        if link.element_type == "junction":
            yield from self._junction_targets(road, key.lane_id, link)
        elif linked_lane is not None:
            yield from self._road_target(link, linked_lane)

    def _road_target(self, link: RoadLink, lane_id: int) -> Iterator[tuple[LaneKey, float]]:
        target_road = self.map.roads.get(link.element_id)
        if target_road is None:
            return
        at_start = link.contact_point != "end"
        target = LaneKey(target_road.id, 0 if at_start else len(target_road.sections) - 1,
                         lane_id)
        if self._drivable(target) and (driving_direction(lane_id) > 0) == at_start:
            yield target, self.entry_s(target)

    def _junction_targets(self, road: Road, lane_id: int,
                          link: RoadLink) -> Iterator[tuple[LaneKey, float]]:
        junction = self.map.junctions.get(link.element_id)
        if junction is None:
            return
        for connection in junction.connections:
            if connection.incoming_road != road.id:
                continue
            for from_lane, to_lane in connection.lane_links:
                if from_lane == lane_id:
                    yield from self._road_target(
                        RoadLink("road", connection.connecting_road, connection.contact_point),
                        to_lane)

    def is_drivable(self, road_id: str | int, lane_id: int, s: float) -> bool:
        """Whether ``lane_id`` of the road at ``s`` is a lane cars drive on."""
        return self._drivable(self.key_at(road_id, lane_id, s))

    def _drivable(self, key: LaneKey) -> bool:
        road = self.map.roads.get(key.road_id)
        if road is None or not 0 <= key.section < len(road.sections):
            return False
        lane = road.sections[key.section].lanes.get(key.lane_id)
        return lane is not None and key.lane_id != 0 and lane.drivable

    @cached_property
    def junction_roads(self) -> frozenset[str]:
        """Ids of the connecting roads inside junctions."""
        return frozenset(r.id for r in self.map.roads.values() if r.in_junction)


def _order(option: tuple[LaneKey, float]) -> tuple[tuple[int, str], int, int]:
    key = option[0]
    return (_numeric(key.road_id), key.section, key.lane_id)


def _numeric(road_id: str) -> tuple[int, str]:
    return (int(road_id), "") if road_id.lstrip("-").isdigit() else (0, road_id)


def _negated(distance: float | None) -> float | None:
    return None if distance is None else -distance

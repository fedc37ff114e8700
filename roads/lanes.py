"""Where lanes are: lateral offsets of lane centres, world poses and distances along a lane.

A lane's centre lies at ``t = laneOffset(s) ± (widths of the lanes between it and the centre
lane + half its own width)``; left lanes (positive ids) on the ``+t`` side. Right lanes drive
along increasing ``s`` and left lanes against it (right-hand traffic), so a lane's heading is
the reference heading, plus pi for left lanes. Distances along a lane integrate
``|dP/ds| = sqrt((1 - curvature t)^2 + t'^2)``: on a curve the outer lanes are longer than
``s`` says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from scenweave.roads.errors import OpenDriveError
from scenweave.roads.opendrive import Lane, LaneSection, Road
from scenweave.roads.plan_view import GL_NODES, GL_WEIGHTS

#: longest piece integrated with one Gauss-Legendre rule (m)
_PIECE_M = 10.0


@dataclass(frozen=True)
class WorldPose:
    """A point in the OpenDRIVE (= OpenSCENARIO) frame: metres, heading in radians."""

    x: float
    y: float
    z: float
    h: float


def driving_direction(lane_id: int) -> int:
    """+1 when traffic on the lane moves towards increasing ``s``, -1 otherwise."""
    return 1 if lane_id < 0 else -1


def normalize_angle(angle: float) -> float:
    """The angle wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _lane(section: LaneSection, lane_id: int, road: Road) -> Lane:
    lane = section.lanes.get(lane_id)
    if lane is None or lane_id == 0:
        raise OpenDriveError(f"road {road.id} has no lane {lane_id} in its lane section starting "
                             f"at s={section.s_start:g}")
    return lane


def lane_border_offsets(road: Road, section: LaneSection, lane_id: int,
                        s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lateral offsets ``t`` of the inner and outer border of a lane, and their slopes dt/ds.

    Returns ``(t_inner, t_outer)`` stacked as arrays of shape ``(2, len(s))`` each holding value
    and slope: ``t[0]`` values, ``t[1]`` slopes.
    """
    _lane(section, lane_id, road)
    sign = 1 if lane_id > 0 else -1
    # a laneOffset record may start exactly where the section ends: the section's own end
    # belongs to the record before it
    s_offset = np.minimum(s, np.nextafter(section.s_end, -np.inf))
    value = road.lane_offset.value(s_offset).astype(float)
    slope = road.lane_offset.slope(s_offset).astype(float)
    for current in range(sign, lane_id, sign):  # the lanes between the centre and this one
        value, slope = _widened(value, slope, sign, _lane(section, current, road), s)
    inner = np.stack([value, slope])
    value, slope = _widened(value, slope, sign, _lane(section, lane_id, road), s)
    return inner, np.stack([value, slope])


def _widened(value: np.ndarray, slope: np.ndarray, sign: int, lane: Lane,
             s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A border's offset and slope moved ``sign``-wards across ``lane``."""
    return value + sign * lane.width.value(s), slope + sign * lane.width.slope(s)


def lane_center_offset(road: Road, section: LaneSection, lane_id: int,
                       s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lateral offset ``t`` of the lane centre line at ``s`` and its slope ``dt/ds``."""
    inner, outer = lane_border_offsets(road, section, lane_id, s)
    centre = (inner + outer) / 2.0
    return centre[0], centre[1]


def section_samples(section: LaneSection, step_m: float = 2.0) -> np.ndarray:
    """``s`` along a lane section about ``step_m`` apart, both ends included (for drawing)."""
    return np.linspace(section.s_start, section.s_end,
                       max(2, int((section.s_end - section.s_start) / step_m) + 1))


def lane_width(road: Road, section: LaneSection, lane_id: int, s: np.ndarray) -> np.ndarray:
    """Width of the lane at ``s``."""
    width: np.ndarray = _lane(section, lane_id, road).width.value(s)
    return width


def lane_pose(road: Road, lane_id: int, s: float, offset: float = 0.0,
              section_index: int | None = None) -> WorldPose:
    """World pose of the centre of ``lane_id`` at ``s``, shifted ``offset`` metres along ``+t``.

    ``offset`` follows OpenDRIVE's ``t``: positive is to the left of the reference line's
    direction. The heading is the direction traffic drives along the lane centre (which
    turns away from the reference heading where the lane widens or narrows).
    ``section_index`` picks the lane section at a section boundary (default: the one traffic
    enters there).
    """
    if not -1e-6 <= s <= road.length + 1e-6:
        raise OpenDriveError(f"road {road.id}: s={s:g} is outside the road (0..{road.length:g})")
    s = min(max(s, 0.0), road.length)
    if section_index is None:
        section_index = road.section_index(s, moving_forward=lane_id < 0)
    section = road.sections[section_index]
    t, slope = lane_center_offset(road, section, lane_id, np.array([s]))
    pose = point_at(road, s, float(t[0]) + offset, lane_id)
    # dP/ds = (1 - curvature t) T + t' N: the centre line's own direction
    curvature = float(road.plan_view.pose(s).curvature[0])
    drift = math.atan2(float(slope[0]), 1.0 - curvature * float(t[0]))
    return WorldPose(pose.x, pose.y, pose.z, normalize_angle(pose.h + drift))


def point_at(road: Road, s: float, t: float, lane_id: int = -1) -> WorldPose:
    """World pose at road coordinates ``(s, t)``, heading along traffic of ``lane_id``'s side."""
    pose = road.plan_view.pose(s)
    hdg = float(pose.hdg[0])
    x = float(pose.x[0]) - t * math.sin(hdg)
    y = float(pose.y[0]) + t * math.cos(hdg)
    z = float(road.elevation.value(s)) + t * math.tan(float(road.superelevation.value(s)))
    heading = hdg if lane_id <= 0 else hdg + math.pi
    return WorldPose(x, y, z, normalize_angle(heading))


def _breakpoints(road: Road, section: LaneSection, s_low: float, s_high: float) -> np.ndarray:
    marks = set(road.plan_view.breakpoints()) | set(road.lane_offset.starts.tolist())
    for lane in section.lanes.values():
        marks |= set(lane.width.starts.tolist())
    inner = sorted(m for m in marks if s_low < m < s_high)
    points = [s_low]
    for mark in [*inner, s_high]:
        pieces = max(1, math.ceil((mark - points[-1]) / _PIECE_M))
        points.extend(np.linspace(points[-1], mark, pieces + 1)[1:].tolist())
    return np.array(points)


def lane_speed_factor(road: Road, section: LaneSection, lane_id: int,
                      s: np.ndarray) -> np.ndarray:
    """``|dP/ds|``: metres driven along the lane centre per metre of ``s``."""
    t, slope = lane_center_offset(road, section, lane_id, s)
    curvature = road.plan_view.pose(s).curvature
    factor: np.ndarray = np.hypot(1.0 - curvature * t, slope)
    return factor


def lane_distance(road: Road, section: LaneSection, lane_id: int, s_a: float,
                  s_b: float) -> float:
    """Distance driven along the centre of ``lane_id`` between ``s_a`` and ``s_b`` (>= 0)."""
    low, high = min(s_a, s_b), max(s_a, s_b)
    if high - low <= 0.0:
        return 0.0
    t = _constant_centre_offset(road, section, lane_id, low, high)
    curvature = road.plan_view.constant_curvature_on(low, high)
    if t is not None and curvature is not None:
        # a lane at constant offset on a line or arc: the integrand is constant (exact)
        return (high - low) * abs(1.0 - curvature * t)
    return integrated_lane_distance(road, section, lane_id, low, high)


def integrated_lane_distance(road: Road, section: LaneSection, lane_id: int, low: float,
                             high: float) -> float:
    """``lane_distance`` by Gauss-Legendre quadrature on pieces of at most ``_PIECE_M``."""
    points = _breakpoints(road, section, low, high)
    spans = np.diff(points)
    nodes = points[:-1, None] + spans[:, None] * GL_NODES
    factor = lane_speed_factor(road, section, lane_id, nodes.ravel()).reshape(nodes.shape)
    return float(spans @ (factor @ GL_WEIGHTS))


def _constant_centre_offset(road: Road, section: LaneSection, lane_id: int, low: float,
                            high: float) -> float | None:
    """The lane centre's ``t`` if the lane offset and every width up to the lane are constant
    on ``[low, high]`` (as ``lane_border_offsets`` evaluates them), else ``None``."""
    sign = 1 if lane_id > 0 else -1
    offset = road.lane_offset.constant_on(min(low, section.s_end), min(
        high, float(np.nextafter(section.s_end, -np.inf))))
    if offset is None:
        return None
    t = offset
    for current in range(sign, lane_id + sign, sign):
        width = _lane(section, current, road).width.constant_on(low, high)
        if width is None:
            return None
        t += sign * (width / 2.0 if current == lane_id else width)
    return t


def s_after_distance(road: Road, section: LaneSection, lane_id: int, s_start: float,
                     distance: float, direction: int) -> float:
    """The ``s`` reached after driving ``distance`` (>= 0) along the lane in ``direction`` (±1)."""
    def clamp(value: float) -> float:
        return min(max(value, section.s_start), section.s_end)

    s = clamp(s_start + direction * distance)  # s and the lane distance differ by a few %
    driven = lane_distance(road, section, lane_id, s_start, s)
    for _ in range(30):
        # Newton on the distance driven; each step integrates only the short stretch it
        # moves over, not the whole way from s_start again
        step = (driven - distance) / float(lane_speed_factor(road, section, lane_id,
                                                             np.array([s]))[0])
        s_next = clamp(s - direction * step)
        moved = lane_distance(road, section, lane_id, s, s_next)
        driven += moved if (s_next - s) * direction >= 0 else -moved
        s = s_next
        if abs(step) < 1e-9:
            break
    return s

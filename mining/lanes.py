"""Positions against the lane geometry: the line between two lanes a car crosses, and the
path a car drives, for the detectors that must not trust a lane label alone (issue 32).

A lane label flips where a lanelet's polygon says, which at junctions, lanelet seams and on
noisy tracks is no lane change; the border the reader's lane map gives
(``mining.readers.lanelet_map``) is the line itself. In town, lanes bend and end in
junctions, so "ahead in my lane" is "on the path I drive next".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenweave.mining.readers.lanelet_map import read_road_network
from scenweave.mining.tracks import Floats, Recording
from scenweave.roads.recorded_road import LaneStrip

#: a border runs on this far straight past its ends, so a point beyond them is measured
#: square to it (m)
BORDER_RUN_ON_M = 30.0
#: a path runs on this far straight along the car's last heading past its last position (m)
PATH_RUN_ON_M = 80.0
#: a lane's successors turning further than this make it a turning lane (deg)
TURN_LANE_DEG = 30.0
#: what a lane map is not read for (the lane labels are then all a detector knows)
MAP_ERRORS = (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError,
              AssertionError)


def lane_map(recording: Recording) -> dict[str, LaneStrip]:
    """The recording's lanelets by id, read from its file; empty where it has none (a
    recording made in memory, NGSIM CSV, a file that no longer reads)."""
    source = Path(recording.source)
    if not source.is_file():
        return {}
    try:
        return {strip.id: strip for strip in read_road_network(source).strips}
    except MAP_ERRORS:
        return {}


def border_between(strips: dict[str, LaneStrip], old: str,
                   new: str) -> tuple[Floats, int] | None:
    """The line between lanelet ``old`` and lanelet ``new`` (a same-direction neighbour of
    it, or of its predecessor or successor: a change across a lanelet seam), as ``old``'s
    border, and the side ``old`` lies on (+1: left of the line in its direction); None where
    the two are no neighbours (a junction's renumbering, a turn, a lane that ends)."""
    if old not in strips or new not in strips:
        return None
    targets = {new, *strips[new].predecessors, *strips[new].successors}
    for name in (old, *strips[old].successors, *strips[old].predecessors):
        strip = strips.get(name)
        if strip is None:
            continue
        if strip.left_same_direction and strip.left_neighbour in targets:
            return strip.left, -1
        if strip.right_same_direction and strip.right_neighbour in targets:
            return strip.right, +1
    return None


def signed_distance(points: Floats, line: Floats) -> Floats:
    """Each point's distance from a polyline (m), + on its left in its direction; the line
    runs on :data:`BORDER_RUN_ON_M` straight past both ends."""
    line = np.asarray(line, dtype=float)
    first, last = line[1] - line[0], line[-1] - line[-2]
    line = np.vstack([line[0] - BORDER_RUN_ON_M * first / max(np.hypot(*first), 1e-9), line,
                      line[-1] + BORDER_RUN_ON_M * last / max(np.hypot(*last), 1e-9)])
    segments = np.diff(line, axis=0)
    j, _, distance, rel = _nearest_segment(line[:-1], segments, points)
    chosen = segments[j]
    cross = chosen[:, 0] * rel[:, 1] - chosen[:, 1] * rel[:, 0]
    return distance * np.where(cross >= 0, 1.0, -1.0)


def path_from(x: Floats, y: Floats, heading: float) -> Floats:
    """The path a car drives from its first given position: its positions, then
    :data:`PATH_RUN_ON_M` straight on along ``heading``."""
    points = np.column_stack([x, y])
    run_on = points[-1] + PATH_RUN_ON_M * np.array([np.cos(heading), np.sin(heading)])
    return np.vstack([points, run_on])


def on_path(path: Floats, points: Floats) -> tuple[Floats, Floats, Floats]:
    """Where each of ``points`` (n x 2) lies against ``path``: how far along it (m, from its
    start), how far off it (m) and the path's heading there (rad)."""
    segments = np.diff(path, axis=0)
    lengths = np.hypot(*segments.T)
    keep = lengths > 1e-6
    if not keep.any():
        return (np.zeros(len(points)), np.hypot(*(points - path[0]).T),
                np.zeros(len(points)))
    segments, lengths, starts = segments[keep], lengths[keep], path[:-1][keep]
    before = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    j, u, off, _ = _nearest_segment(starts, segments, points)
    return (before[j] + u * lengths[j], off, np.arctan2(segments[j, 1], segments[j, 0]))


def _nearest_segment(starts: Floats, segments: Floats,
                     points: Floats) -> tuple[np.ndarray, Floats, Floats, Floats]:
    """For each point, the polyline segment nearest to it: its index, how far along it the
    nearest point lies (0..1), the distance, and the point relative to the segment's start."""
    squared = np.maximum(np.einsum("ij,ij->i", segments, segments), 1e-12)
    rel = points[:, None, :] - starts[None, :, :]
    u = np.clip(np.einsum("pij,ij->pi", rel, segments) / squared, 0.0, 1.0)
    off = np.hypot(*np.moveaxis(rel - u[..., None] * segments[None], -1, 0))
    j = np.argmin(off, axis=1)
    rows = np.arange(len(points))
    return j, u[rows, j], off[rows, j], rel[rows, j]


def lane_movement(strips: dict[str, LaneStrip], lane: str) -> str | None:
    """The one movement lane ``lane`` leads to, from the map: ``left`` or ``right`` when
    every successor turns that way by more than :data:`TURN_LANE_DEG` (a turning lane,
    with its own arrow), ``straight`` when every one runs on within it; None where they
    differ or the map does not say (a shared approach: the car's own path decides)."""
    strip = strips.get(lane)
    if strip is None or not strip.successors:
        return None
    found = set()
    for name in strip.successors:
        after = strips.get(name)
        if after is None:
            return None
        turn = _heading(after.centre[-2:]) - _heading(strip.centre[-2:])
        deg = float(np.degrees(np.angle(np.exp(1j * turn))))
        found.add("left" if deg > TURN_LANE_DEG else "right" if deg < -TURN_LANE_DEG
                  else "straight" if abs(deg) <= TURN_LANE_DEG else None)
    return found.pop() if len(found) == 1 else None


def _heading(points: Floats) -> float:
    step = points[-1] - points[0]
    return float(np.arctan2(step[1], step[0]))

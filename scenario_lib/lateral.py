"""A mined lane change timed as recorded: it starts when the car started to move across,
crosses the line when it crossed and settles when it settled (issue 31).

One linear LaneChangeAction crosses the line halfway through its lateral path, yet recorded
lane changes cross anywhere from early to late in them, and a car recorded mid-change starts
off its lane's centre. So a mined lane change is two actions (docs/scenario-conventions.md):

- ``<entity>_lane_change``: from ``maneuver_start_s``, where the car starts across its lane
  (``<actor>_lane_offset_m``), linearly toward the new lane's centre, as fast as makes it
  reach the line at ``lane_change_cross_s``;
- ``<entity>_lane_settle``: :data:`SETTLE_AFTER_CROSSING_S` after the crossing (or once
  :data:`SETTLE_PAST_LINE_M` past the line, for a slow move), from where it is
  to the centre of the lane it is now in, by the end of ``duration_s`` (it replaces the first,
  which runs on the same lateral domain; at least :data:`MIN_SETTLE_S`).

Both are given as the distance the car drives meanwhile (dynamics ``distance``: scenario_runner
ignores ``time`` for a LaneChangeAction; docs/scenario-conventions.md), from its speed profile.

A record without these keys (MOOVE rows: begin/end values and a duration) keeps the single
linear change over ``duration_s``. Arithmetic on params and the speed profile: the builder
and the judge both use it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from scenweave.scenario_lib.kinematics import LANE_CHANGE_MIN_LENGTH_M
from scenweave.scenario_lib.phases import profile_of

#: the settling part starts this long after the car crossed the line (s): by then it is in
#: its new lane, which "this lane" (RelativeTargetLane 0) then names
SETTLE_AFTER_CROSSING_S = 0.2
SETTLE_PAST_LINE_M = 0.25
#: a car must start at least this far before the line (m) and cross at least this long after
#: the manoeuvre starts (s) for the crossing to be timed; else the single change plays
MIN_TO_LINE_M = 0.05
MIN_CROSS_S = 0.05
#: a settling part lasts at least this long (s) and this far (m; the first part's floor,
#: 5 m, would slow a short one down)
MIN_SETTLE_S = 0.2
MIN_SETTLE_M = 1.0


@dataclass(frozen=True)
class RecordedLaneChange:
    """When the parts of a recorded lane change run, in scenario time (s)."""

    #: the first part starts (``maneuver_start_s``) and lasts this long (linear in time)
    start_s: float
    first_s: float
    #: the car crosses the line then
    cross_s: float
    #: the settling part starts then and lasts this long
    settle_start_s: float | None
    settle_s: float | None
    #: where the car starts across its lane, toward the new lane (m)
    offset_toward_m: float
    #: the distance the car drives during each part (m): the actions' dynamics
    first_m: float = 0.0
    settle_m: float | None = None


def recorded_lane_change(params: Mapping[str, Any], prefix: str) -> RecordedLaneChange | None:
    """The two parts of ``prefix``'s recorded lane change (``ego`` or ``npc``), None when params
    do not time it (no ``lane_change_cross_s``) or it cannot be timed so (the car starts at
    or past the line, or crosses as the manoeuvre starts)."""
    values = [_number(params.get(key)) for key in ("lane_change_cross_s", "lane_change_width_m",
                                                   "maneuver_start_s", "duration_s")]
    if None in values:
        return None
    cross, width, start, duration = (v or 0.0 for v in values)
    toward = (1.0 if params.get("lane_change_direction") == "left" else -1.0) \
        * (_number(params.get(f"{prefix}_lane_offset_m")) or 0.0)
    to_line = width / 2 - toward
    if to_line < MIN_TO_LINE_M or cross < MIN_CROSS_S:
        return None
    # linear in the distance driven (the dynamics' dimension): the line is reached after
    # the metres driven until ``cross``, so the crossing keeps its time whatever the speed
    driven = profile_of(params, prefix).distance
    across = width - toward
    path_m = (driven(start + cross) - driven(start)) * across / to_line
    first_m = _length(along_lane_m(path_m, across))
    first = cross * across / to_line  # the same, in time at a steady speed
    # settling starts once the car is clearly in its new lane ("this lane" must be the new
    # one): SETTLE_AFTER_CROSSING_S, or longer for a slow move, SETTLE_PAST_LINE_M across
    past_line_s = SETTLE_PAST_LINE_M * first / (width - toward)
    settle_from = cross + max(SETTLE_AFTER_CROSSING_S, past_line_s)
    # as long as recorded, but not shorter than MIN_SETTLE_S: a quicker one ends a little late
    settle = max(duration - settle_from, MIN_SETTLE_S)
    # what is left across at the settling's start, along a straight slanted path
    left_m = across * max(1.0 - (driven(start + settle_from) - driven(start)) / path_m, 0.0) \
        if path_m > 0 else 0.0
    settle_path_m = driven(start + settle_from + settle) - driven(start + settle_from)
    settle_m = max(round(along_lane_m(settle_path_m, left_m), 3), MIN_SETTLE_M)
    return RecordedLaneChange(start, _ms(first), start + cross, _ms(start + settle_from),
                              _ms(settle), toward, first_m, settle_m)


def along_lane_m(path_m: float, across_m: float) -> float:
    """The length along the lane of a lane change whose car drives ``path_m`` (its speed
    profile's distance) meanwhile, ``across_m`` of it across. A player moves a changing car
    at its speed along its slanted path and counts the change's length along the lane (esmini
    3.6: a car at 2.1 m/s gains 1.93 m/s of road while it changes lanes), and a recorded speed
    is the path's too; at town speeds (3.5 m across in 8 m) the path is 9 % longer than the
    lane, and a change sized by the path crossed 0.24 s late (issue 36)."""
    return math.sqrt(max(path_m * path_m - across_m * across_m, 0.0))


def _length(metres: float) -> float:
    """A lane change's length as the file gives it: millimetres, at least the floor below
    which a player makes it a jump."""
    return max(LANE_CHANGE_MIN_LENGTH_M, round(metres, 3))


def road_offset(params: Mapping[str, Any], actor: str) -> float | int:
    """``<actor>_lane_offset_m`` (+ to the left of its travel) as OpenDRIVE's ``t`` (+ to the
    left of the road's reference line): cars in negative lanes drive along it, in positive
    lanes against it. 0 (the lane's centre) without it."""
    left = _number(params.get(f"{actor}_lane_offset_m"))
    lane = _number(params.get(f"{actor}_lane_id"))
    if left is None or lane is None:
        return 0
    return round(left if lane < 0 else -left, 3)


def _number(value: Any) -> float | None:
    """``value`` as a float when it is a finite number, else None."""
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def _ms(value: float) -> float:
    return round(value, 3)

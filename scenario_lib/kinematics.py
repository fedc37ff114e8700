"""When things happen and where cars are: the timing rules of the reference scenarios.

Pure arithmetic on speeds, distances and times, shared by the reference scripts (through
``builder``) and by the judge (``judge``), so the scenario and its check derive a
trigger time or a start gap from the params the same way. Every rule is documented in
``docs/scenario-conventions.md``. Imports nothing but the standard library: it runs in the
sandbox too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

#: how long a light shows yellow before it turns red (s)
YELLOW_PHASE_S = 3.0
#: shortest lane change scenario_runner is asked for (m); below it the change is a jump
LANE_CHANGE_MIN_LENGTH_M = 5.0
#: time between the cue (a light turning yellow, the lead braking) and the ego's reaction (s)
REACTION_TIME_S = 1.0
#: a played gap to the ego may differ this much from the record's (m): the replay judge's
#: tolerance, which ingest's one-ramp choice of an end gap and mining's round trip keep too
GAP_TOL_M = 1.0
#: the stopping ego comes to rest this far before the stop line (m)
STOP_LINE_MARGIN_M = 1.0
#: a passing-on-orange light turns yellow when the ego is this far before the stop line (m)
YELLOW_BEFORE_STOP_LINE_M = 5.0
#: earliest time a light changes after its initial state at t = 0 (s)
FIRST_LIGHT_CHANGE_S = 0.5
#: the hardest braking the ego is given when it must stop or react in time (m/s^2)
MAX_DECELERATION_MS2 = 8.0
#: the hardest braking and acceleration a scenario's vehicles are capable of (m/s^2): their
#: OpenSCENARIO Performance; a record that needs more cannot be played back
MAX_PLAYABLE_DECELERATION_MS2 = 10.0
#: a speed this small is standing still (m/s)
STANDING_MS = 1e-6
#: free space kept between the ego and a braking lead, bumper to bumper (m)
SAFETY_GAP_M = 2.0


class Motion(Protocol):
    """A car's longitudinal motion from t = 0: one ramp (:class:`SpeedProfile`) or a list of
    phases (``phases.PhasedProfile``); the timing rules below take either."""

    @property
    def v0(self) -> float: ...

    @property
    def end_speed(self) -> float: ...

    @property
    def start_s(self) -> float: ...

    @property
    def end_s(self) -> float: ...

    @property
    def duration_s(self) -> float: ...

    def speed(self, t: float) -> float: ...

    def distance(self, t: float) -> float: ...

    def time_to_cover(self, metres: float) -> float: ...

    def breakpoints(self) -> tuple[float, ...]: ...

    def hardest_braking_ms2(self) -> float: ...


@dataclass(frozen=True)
class SpeedProfile:
    """Speed ``v0`` until ``start_s``, then linearly to ``v1`` within ``duration_s``."""

    v0: float
    v1: float
    start_s: float
    duration_s: float

    @property
    def end_speed(self) -> float:
        return self.v1

    @property
    def end_s(self) -> float:
        return self.start_s + max(self.duration_s, 0.0)

    def speed(self, t: float) -> float:
        if t <= self.start_s:
            return self.v0
        if t >= self.end_s:
            return self.end_speed
        return self.v0 + (self.end_speed - self.v0) * (t - self.start_s) / self.duration_s

    def distance(self, t: float) -> float:
        """Metres driven from t = 0 to ``t``."""
        if t <= self.start_s:
            return self.v0 * t
        ramp_t = min(t, self.end_s) - self.start_s
        ramp_m = (self.v0 + self.speed(self.start_s + ramp_t)) / 2 * ramp_t
        covered = self.v0 * self.start_s + ramp_m
        return covered + self.end_speed * max(t - self.end_s, 0.0)

    def time_to_cover(self, metres: float) -> float:
        """When the car has driven ``metres`` (``math.inf`` if it stops first)."""
        if metres <= 0:
            return 0.0
        if self.v0 > 0 and self.v0 * self.start_s >= metres:
            return metres / self.v0
        low, high = self.start_s, self.end_s
        if self.distance(high) < metres:
            return high + (metres - self.distance(high)) / self.end_speed \
                if self.end_speed > 0 else math.inf
        return _bisect(lambda t: self.distance(t) >= metres, low, high)

    def breakpoints(self) -> tuple[float, float]:
        return self.start_s, self.end_s

    def hardest_braking_ms2(self) -> float:
        """How hard the ramp slows down (m/s^2; infinite for a jump, 0 when it speeds up)."""
        if self.v0 <= self.v1:
            return 0.0
        return math.inf if self.duration_s <= 0 else (self.v0 - self.v1) / self.duration_s


def _bisect(reached: Callable[[float], bool], low: float, high: float) -> float:
    """Smallest t in [low, high] with ``reached(t)`` (monotone), to 1e-6 s."""
    for _ in range(60):
        middle = (low + high) / 2
        low, high = (low, middle) if reached(middle) else (middle, high)
        if high - low < 1e-6:
            break
    return high


def lane_change_length_m(v_start_ms: float, v_end_ms: float, duration_s: float) -> float:
    """Distance driven during a lane change of ``duration_s`` (scenario_runner wants metres)."""
    return max(LANE_CHANGE_MIN_LENGTH_M, (v_start_ms + v_end_ms) / 2 * duration_s)


def start_gap_m(gap_at_manoeuvre_m: float, npc_speed_ms: float, ego_speed_ms: float,
                maneuver_start_s: float) -> float:
    """The gap at t = 0 that becomes ``gap_at_manoeuvre_m`` at ``maneuver_start_s``.

    Both cars hold their start speeds until the manoeuvre starts, so the gap changes by the
    speed difference times the lead-in time.
    """
    return gap_at_manoeuvre_m - (npc_speed_ms - ego_speed_ms) * maneuver_start_s


def min_gap_m(lead: Motion, follower: Motion, gap_m: float, until_s: float,
              from_s: float = 0.0) -> float:
    """Smallest distance between two cars in one lane over [``from_s``, ``until_s``].

    ``gap_m`` is the distance at t = 0 (lead ahead, positive). Between breakpoints both
    speeds are linear, so the gap is a parabola: its ends and its vertex (equal speeds) suffice.
    """
    times = sorted({from_s, until_s, *(t for t in (*lead.breakpoints(), *follower.breakpoints())
                                       if from_s < t < until_s)})

    def gap(t: float) -> float:
        return gap_m + lead.distance(t) - follower.distance(t)

    smallest = min(gap(t) for t in times)
    for a, b in zip(times, times[1:], strict=False):
        closing_a = lead.speed(a) - follower.speed(a)
        closing_b = lead.speed(b) - follower.speed(b)
        if closing_a < 0 < closing_b:  # equal speeds inside: the parabola's vertex
            smallest = min(smallest, gap(a + (b - a) * closing_a / (closing_a - closing_b)))
    return smallest


def lead_reaction(ego_speed_ms: float, ego_end_speed_ms: float, lead: Motion,
                  gap_m: float, until_s: float, clearance_m: float,
                  cut_in: bool = False) -> SpeedProfile | None:
    """The ego's reaction to a car that ends up in front of it slower than the ego would drive,
    or ``None`` when the car ends no slower than ``ego_end_speed_ms`` (the ego drives as
    recorded).

    A braking lead (``cut_in`` false) shares the ego's lane all along; a cutter (``cut_in``)
    enters it when its manoeuvre starts, so only the distance from then on counts.
    """
    if lead.end_speed >= ego_end_speed_ms:
        return None
    return ego_reaction(ego_speed_ms, lead, gap_m, until_s, clearance_m,
                        from_s=lead.start_s if cut_in else 0.0)


def ego_reaction(ego_speed_ms: float, lead: Motion, gap_m: float, until_s: float,
                 clearance_m: float, from_s: float = 0.0) -> SpeedProfile:
    """The ego's answer to a lead that slows down: go to its end speed after a reaction time.

    The ego keeps ``ego_speed_ms`` until ``REACTION_TIME_S`` after the lead starts braking,
    then changes to the lead's end speed over the lead's braking time, or faster when that
    would bring the two closer than ``clearance_m`` (centre to centre) before ``until_s``: the
    longest braking time that keeps the distance, braking at most as hard as the lead did or
    ``MAX_DECELERATION_MS2``, whichever is harder (what the record shows a car doing). When
    even that is too late (the record's ego did not crash, so it reacted faster), the ego
    starts braking earlier: the latest start, down to the lead's own, that keeps the distance.
    The distance is watched from ``from_s`` on (a cutter is in the ego's lane only then).
    """
    target = lead.end_speed
    shortest = max(ego_speed_ms - target, 0.0) / max_deceleration_ms2(lead)
    longest = max(lead.duration_s, shortest)

    def safe(start: float, duration: float) -> bool:
        ego = SpeedProfile(ego_speed_ms, target, start, duration)
        return min_gap_m(lead, ego, gap_m, until_s, from_s) >= clearance_m

    start = lead.start_s + REACTION_TIME_S
    if not safe(start, shortest):
        if not safe(lead.start_s, shortest):  # no reaction keeps the distance
            return SpeedProfile(ego_speed_ms, target, lead.start_s, shortest)
        start = _latest(lambda t: safe(t, shortest), lead.start_s, start)
        return SpeedProfile(ego_speed_ms, target, start, shortest)
    if safe(start, longest):
        return SpeedProfile(ego_speed_ms, target, start, longest)
    return SpeedProfile(ego_speed_ms, target, start,
                        _latest(lambda d: safe(start, d), shortest, longest))


def lead_stays_ahead(lead_speed_ms: float, ego: Motion, gap_m: float, until_s: float,
                     clearance_m: float) -> SpeedProfile | None:
    """The lead's speed when an ego faster than it would otherwise catch up before ``until_s``.

    A record gives the lead one speed and the ego its own profile; held past the recorded
    window, a slower lead is run into. The lead then speeds up from t = 0 to the ego's top
    speed, as gently as keeps ``clearance_m`` (centre to centre); ``None`` when its recorded
    speed already keeps it.
    """
    top = max(ego.v0, ego.end_speed)

    def safe(duration: float) -> bool:
        lead = SpeedProfile(lead_speed_ms, top, 0.0, duration)
        return min_gap_m(lead, ego, gap_m, until_s) >= clearance_m

    steady = SpeedProfile(lead_speed_ms, lead_speed_ms, 0.0, 0.0)
    if lead_speed_ms >= top or min_gap_m(steady, ego, gap_m, until_s) >= clearance_m:
        return None
    if not safe(0.0):
        return SpeedProfile(lead_speed_ms, top, 0.0, 0.0)
    if safe(until_s):
        return SpeedProfile(lead_speed_ms, top, 0.0, round(until_s, 3))
    return SpeedProfile(lead_speed_ms, top, 0.0, _latest(safe, 0.0, until_s))


def follower_settles(follower_ms: float, leader_ms: float, gap_m: float, within_s: float,
                     clearance_m: float) -> float | None:
    """How long a follower may take to slow to its leader's speed, starting now, so that the
    two stay ``clearance_m`` apart (centre to centre) for ``within_s``; ``None`` when holding
    its speed already keeps the distance. 0.0 (at once) is the best left when nothing keeps it.
    """
    leader = SpeedProfile(leader_ms, leader_ms, 0.0, 0.0)

    def safe(duration: float) -> bool:
        follower = SpeedProfile(follower_ms, leader_ms, 0.0, duration)
        return min_gap_m(leader, follower, gap_m, within_s) >= clearance_m

    holding = SpeedProfile(follower_ms, follower_ms, 0.0, 0.0)
    if follower_ms <= leader_ms or min_gap_m(leader, holding, gap_m, within_s) >= clearance_m:
        return None
    if not safe(0.0):
        return 0.0
    return within_s if safe(within_s) else _latest(safe, 0.0, within_s)


def _latest(ok: Callable[[float], bool], low: float, high: float) -> float:
    """Largest x in [low, high] with ``ok(x)``, given ``ok(low)`` and not ``ok(high)``,
    rounded down to the millisecond so it stays on the safe side."""
    for _ in range(40):
        middle = (low + high) / 2
        low, high = (middle, high) if ok(middle) else (low, middle)
    return math.floor(low * 1000) / 1000


def max_deceleration_ms2(lead: Motion) -> float:
    """The hardest braking the ego is given behind ``lead``: the lead's hardest (of its
    hardest phase, when it has several) or the default."""
    return max(MAX_DECELERATION_MS2, lead.hardest_braking_ms2())


def stop_at_line(ego_speed_ms: float, brake_time_s: float,
                 stop_line_m: float) -> SpeedProfile:
    """The ego cruises, then brakes to 0 so that it comes to rest before the stop line.

    It brakes over the recorded ``brake_time_s`` (shorter, when the stop line is too close
    for that) and starts braking so it stops ``STOP_LINE_MARGIN_M`` before the line.
    """
    if ego_speed_ms <= STANDING_MS:  # (a denormal speed would put the braking at infinity)
        return SpeedProfile(ego_speed_ms, 0.0, 0.0, brake_time_s)
    room = max(stop_line_m - STOP_LINE_MARGIN_M, 0.0)
    duration = min(brake_time_s, 2 * room / ego_speed_ms)
    start = (room - ego_speed_ms * duration / 2) / ego_speed_ms
    return SpeedProfile(ego_speed_ms, 0.0, round(start, 3), round(duration, 3))


def red_light_timing(stop: SpeedProfile) -> tuple[str, float]:
    """A stop at red: ``(state at t = 0, time the light turns yellow)``.

    The light turns yellow ``REACTION_TIME_S`` before the ego starts braking. When the ego
    must brake so early that there is no time for that, the light is yellow from the start
    (the ego never brakes on green); the yellow event then comes at ``FIRST_LIGHT_CHANGE_S``.
    """
    cue = stop.start_s - REACTION_TIME_S
    return ("green" if cue >= FIRST_LIGHT_CHANGE_S else "yellow",
            round(max(cue, FIRST_LIGHT_CHANGE_S), 3))


def orange_light_yellow_s(ego: Motion, stop_line_m: float) -> float:
    """A pass on orange: the light turns yellow as the ego is 5 m before the stop line."""
    reached = ego.time_to_cover(stop_line_m - YELLOW_BEFORE_STOP_LINE_M)
    return round(max(reached, FIRST_LIGHT_CHANGE_S), 3)

"""Fitting speed phases (``corpus.phases``) to what a record says about an actor's speed.

Two kinds of record:

- **with series** (mined records carry each actor's speed at every recorded sample): the
  fewest linear phases that keep the speed within ``SPEED_TOL_MS`` and the distance travelled
  since the first sample within ``DISTANCE_TOL_M`` of the record at every sample
  (:func:`fit_series`);
- **begin/end values only** (MOOVE tables): one ramp when it reproduces the record, else the
  smallest profile that meets both speeds, the duration and the distance the end gap needs
  (:func:`fit_end_values`; FL classes). :class:`NoProfile` says why none can.

Times in a phase are simulation times: the record's t = 0 is the scenario's
``maneuver_start_s``. Every number is rounded to the millisecond (the scenario file's digits).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from scenweave.corpus.kinematics import MAX_PLAYABLE_DECELERATION_MS2
from scenweave.corpus.phases import Phase, PhasedProfile

#: a fitted profile's speed may differ this much from a recorded sample (m/s)
SPEED_TOL_MS = 0.3
#: ... and the distance it drove since the first sample this much (m)
DISTANCE_TOL_M = 0.5
#: a begin/end record's end gap, played by one ramp, may be off this much (m): the replay's
#: gap tolerance (``schemas.replay.GAP_TOL_M``)
END_GAP_TOL_M = 1.0
#: a phase changing the speed less than this is no phase (m/s)
NO_CHANGE_MS = 1e-3
#: a phase's corner speed may lie this far from the recorded sample it ends at (m/s): room to
#: keep the distance where speeds and positions of a record disagree a little
CORNER_SHIFTS_MS = (0.0, -0.1, 0.1, -0.2, 0.2)
#: a segment that left a tolerance is tried this many samples further before giving up
LOOK_AHEAD = 3
#: where a two-phase profile may put its corner, as shares of the duration
CORNERS = tuple(k / 100 for k in range(5, 96))


class NoProfile(ValueError):
    """No phase profile can show the record: the message says why."""


def fit_series(times: Sequence[float | None], speeds: Sequence[float | None], start_s: float,
               v_start: float, positions: Sequence[float | None] | None = None,
               relative: Sequence[float | None] | None = None) -> tuple[Phase, ...]:
    """The fewest linear phases, from ``v_start`` at ``start_s``, that follow the recorded
    ``speeds`` at ``times`` (record time; None values are gaps in the record), and the
    distance driven since the first sample: the recorded ``positions`` along the road where
    every sample has one (what the record's gaps are measured from), else the speeds'
    trapezoid. ``relative``: distances the fit must also keep within ``DISTANCE_TOL_M``
    where given (an NPC's: the ego's fitted distance plus the recorded gap's change, so the
    gap holds as well as each car's own motion)."""
    n = len(times)
    rows = [(t, v, x, r) for t, v, x, r in zip(times, speeds, positions or [0.0] * n,
                                               relative or [None] * n, strict=False)
            if t is not None and v is not None]
    if len(rows) < 2:
        return ()
    t, v = [float(r[0]) for r in rows], [float(r[1]) for r in rows]
    if positions is not None and all(r[2] is not None for r in rows):
        driven = [float(r[2]) - float(rows[0][2]) for r in rows]
    else:
        driven = [0.0]
        for k in range(1, len(t)):
            driven.append(driven[-1] + (v[k] + v[k - 1]) / 2 * (t[k] - t[k - 1]))
    targets = [(driven, DISTANCE_TOL_M)]
    if relative is not None:
        targets.append(([r[3] for r in rows], DISTANCE_TOL_M))
    phases: list[Phase] = []
    knot = v_start
    if abs(v_start - v[0]) > SPEED_TOL_MS:  # the record's first sample differs from its field
        phases.append(Phase(_ms(start_s + t[0]), 0.0, _ms(v[0]), "step"))
        knot = v[0]
    i, fitted = 0, 0.0
    while i < len(t) - 1:
        j, corner, fitted = _longest_segment(t, v, targets, i, knot, fitted)
        if abs(corner - knot) > NO_CHANGE_MS:
            phases.append(Phase(_ms(start_s + t[i]), _ms(t[j] - t[i]), _ms(corner)))
        i, knot = j, _ms(corner)
    return tuple(phases)


Targets = list[tuple[list[float | None], float]]


def _longest_segment(t: list[float], v: list[float], targets: Targets, i: int, knot: float,
                     fitted: float) -> tuple[int, float, float]:
    """The furthest sample ``j`` a straight line from ``(t[i], knot)`` to ``(t[j], corner)``
    reaches within both tolerances at every sample between, ``corner`` one of the speeds near
    ``v[j]`` that keeps the distance closest; and the fitted distance at ``t[j]``
    (``fitted``: at ``t[i]``). Without any, the next sample, as close as it gets."""
    best: tuple[int, float, float] | None = None
    for j in range(i + 1, len(t)):
        options = [o for o in (_segment(t, v, targets, i, j, knot, fitted, v[j] + shift)
                               for shift in CORNER_SHIFTS_MS) if o is not None]
        if options:
            corner, reached, _ = min(options, key=lambda o: o[2])
            best = (j, corner, reached)
        elif best is not None and j - best[0] > LOOK_AHEAD:
            break
    if best is None:
        corner = v[i + 1]
        reached = fitted + (knot + corner) / 2 * (t[i + 1] - t[i])
        return i + 1, corner, reached
    return best


def _segment(t: list[float], v: list[float], targets: Targets, i: int, j: int, knot: float,
             fitted: float, corner: float) -> tuple[float, float, float] | None:
    """``(corner, fitted distance at t[j], worst distance error)`` of the line from
    ``(t[i], knot)`` to ``(t[j], corner)``, or None when it leaves a tolerance."""
    if corner < 0:
        return None
    slope = (corner - knot) / (t[j] - t[i]) if t[j] > t[i] else 0.0
    reached, worst, previous = fitted, 0.0, knot
    for k in range(i + 1, j + 1):
        speed = knot + slope * (t[k] - t[i])
        if abs(speed - v[k]) > SPEED_TOL_MS + 1e-9:
            return None
        reached += (previous + speed) / 2 * (t[k] - t[k - 1])
        previous = speed
        for wanted, tolerance in targets:
            if wanted[k] is not None and abs(reached - wanted[k]) > tolerance:
                return None
        worst = max(worst, abs(reached - targets[0][0][k]))
    return corner, reached, sum(abs(reached - w[j]) for w, _ in targets if w[j] is not None)


def fit_end_values(v0: float, v1: float, start_s: float, duration_s: float,
                   distance_m: float | None) -> tuple[Phase, ...]:
    """The profile from ``v0`` to ``v1`` within ``duration_s`` from ``start_s`` that drives
    ``distance_m`` meanwhile (within ``END_GAP_TOL_M``): one ramp when that does, else two
    phases through the gentlest corner speed, else a stop between braking and pulling away.
    ``distance_m`` None: no distance is recorded, one ramp. Raises :class:`NoProfile`."""
    ramp = (Phase(start_s, duration_s, v1),)
    if distance_m is None or abs((v0 + v1) / 2 * duration_s - distance_m) <= END_GAP_TOL_M:
        return ramp
    if distance_m < 0:
        raise NoProfile(f"it would have to drive {distance_m:.1f} m, backwards, in "
                        f"{duration_s:g} s")
    if duration_s <= 0:
        raise NoProfile("the record takes no time, yet the distance changes")
    best = min((_two_phases(v0, v1, start_s, duration_s, distance_m, share)
                for share in CORNERS), key=_hardest, default=None)
    candidates = [c for c in (best, _stop_between(v0, v1, start_s, duration_s, distance_m))
                  if c is not None]
    if not candidates:
        raise NoProfile(f"no speeds from {v0:.1f} to {v1:.1f} m/s cover {distance_m:.1f} m in "
                        f"{duration_s:g} s")
    gentlest = min(candidates, key=_hardest)
    worst = _hardest(gentlest)
    if worst > MAX_PLAYABLE_DECELERATION_MS2:
        raise NoProfile(f"to go from {v0:.1f} to {v1:.1f} m/s and cover {distance_m:.1f} m in "
                        f"{duration_s:g} s a car must change speed by {worst:.1f} m/s^2; "
                        f"vehicles manage {MAX_PLAYABLE_DECELERATION_MS2:g}")
    return gentlest[1]


def _hardest(candidate: tuple[float, tuple[Phase, ...]] | None) -> float:
    return math.inf if candidate is None else candidate[0]


def _two_phases(v0: float, v1: float, start_s: float, duration_s: float, distance_m: float,
                share: float) -> tuple[float, tuple[Phase, ...]] | None:
    corner = _ms(duration_s * share)
    middle = (2 * distance_m - v0 * corner - v1 * (duration_s - corner)) / duration_s
    if middle < 0:
        return None
    phases = (Phase(start_s, corner, _ms(middle)),
              Phase(_ms(start_s + corner), _ms(duration_s - corner), v1))
    return PhasedProfile(v0, phases).max_acceleration_ms2(), phases


def _stop_between(v0: float, v1: float, start_s: float, duration_s: float,
                  distance_m: float) -> tuple[float, tuple[Phase, ...]] | None:
    """Brake to a standstill, wait, pull away: for a distance shorter than any two ramps
    cover. Braking and pulling away share one rate: (v0^2 + v1^2) / (2 distance)."""
    if distance_m <= 0 or v0 + v1 <= 0:
        return None
    rate = (v0 * v0 + v1 * v1) / (2 * distance_m)
    braking, pulling = _ms(v0 / rate), _ms(v1 / rate)
    if braking + pulling > duration_s:
        return None
    phases = (Phase(start_s, braking, 0.0),
              Phase(_ms(start_s + duration_s - pulling), pulling, v1))
    return rate, tuple(p for p in phases if p.duration_s > 0 or p.target_ms > 0)


def _ms(value: float) -> float:
    """Rounded to the millisecond (or mm/s): what the scenario file shows."""
    return round(value, 3)

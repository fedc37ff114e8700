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
#: where a two-phase profile may put its corner, as shares of the duration
CORNERS = tuple(k / 100 for k in range(5, 96))


class NoProfile(ValueError):
    """No phase profile can show the record: the message says why."""


def fit_series(times: Sequence[float | None], speeds: Sequence[float | None], start_s: float,
               v_start: float) -> tuple[Phase, ...]:
    """The fewest linear phases, from ``v_start`` at ``start_s``, that follow the recorded
    ``speeds`` at ``times`` (record time; None values are gaps in the record)."""
    samples = [(float(t), float(v)) for t, v in zip(times, speeds, strict=False)
               if t is not None and v is not None]
    if len(samples) < 2:
        return ()
    t, v = [s[0] for s in samples], [s[1] for s in samples]
    phases: list[Phase] = []
    knot = v_start
    if abs(v_start - v[0]) > SPEED_TOL_MS:  # the record's first sample differs from its field
        phases.append(Phase(_ms(start_s + t[0]), 0.0, _ms(v[0]), "step"))
        knot = v[0]
    i, drift = 0, 0.0
    while i < len(t) - 1:
        j, drift = _longest_segment(t, v, i, knot, drift)
        if abs(v[j] - knot) > NO_CHANGE_MS:
            phases.append(Phase(_ms(start_s + t[i]), _ms(t[j] - t[i]), _ms(v[j])))
        i, knot = j, v[j]
    return tuple(phases)


def _longest_segment(t: list[float], v: list[float], i: int, knot: float,
                     drift: float) -> tuple[int, float]:
    """The furthest sample ``j`` a straight line from ``(t[i], knot)`` to ``(t[j], v[j])``
    reaches within both tolerances at every sample between, and the distance drift there.
    ``drift`` is the fitted minus the recorded distance at ``t[i]``."""
    best = (i + 1, drift + (knot - v[i]) / 2 * (t[i + 1] - t[i]))
    for j in range(i + 1, len(t)):
        slope = (v[j] - knot) / (t[j] - t[i]) if t[j] > t[i] else 0.0
        moved, ok = drift, True
        previous_error = knot - v[i]
        for k in range(i + 1, j + 1):
            error = knot + slope * (t[k] - t[i]) - v[k]
            moved += (previous_error + error) / 2 * (t[k] - t[k - 1])
            previous_error = error
            if abs(error) > SPEED_TOL_MS + 1e-9:
                return best
            if abs(moved) > DISTANCE_TOL_M:
                ok = False
        if ok:
            best = (j, moved)
    return best


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

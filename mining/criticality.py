"""How critical a mined event is, from the series its record carries (issue 32 item 5).

Every number is measured on the recorded positions as the record's series gives them
(``<role>_s_m``, the bumper gaps ``<role>_gap_m`` from them, ``<role>_lateral_m``, and
``<role>_speed_raw_ms``: the positions' change averaged over 0.5 s), never on the detectors'
Savitzky-Golay smoothing, and never on a sample the series marks as tracking noise
(``<role>_noise``): a tracker's jump is no braking and no closing in.

- ``ttc_min_s``: the least time to collision between the ego and a vehicle of its own lane
  (a series role with a gap whose lane equals the ego's at that step): bumper gap / closing
  speed, the follower's speed minus the lead's, at the steps where the follower closes in.
  None when no pair ever closes in (a free ride; a lead that pulls away).
- ``thw_min_s``: the least time headway of the same pairs: bumper gap / the follower's speed
  (a follower slower than :data:`MOVING_MS` has none).
- ``brake_1s_max_ms2``: the hardest 1 s of braking of the event's vehicles (ego and NPC): the
  largest mean deceleration ``(v(t) - v(t + 1 s)) / 1 s`` over any 1 s window free of noise;
  0 when nobody slows down; None when the event is shorter than 1 s.
- ``lat_acc_peak_ms2``: the largest sideways acceleration of the event's vehicles across
  their lane's course (a lane change's swerve): the second difference of the lateral
  position over +-0.5 s. The series holds no heading, so a turn's own centripetal
  acceleration is not in it.

A value that cannot be measured is None, written ``null`` in JSON (never NaN or infinity).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from scenweave.mining.tracks import Floats, Mask

#: the four numbers every mined record carries under ``criticality``, in this order
CRITICALITY_FIELDS = ("ttc_min_s", "thw_min_s", "brake_1s_max_ms2", "lat_acc_peak_ms2")
#: the span of the braking window and of the lateral second difference (s)
WINDOW_S = 1.0
#: a follower slower than this (m/s) has no time headway (it is standing)
MOVING_MS = 0.5
#: the event's own vehicles, whose braking and swerving count (free rides' neighbours do not)
EVENT_ROLES = ("ego", "npc")


def criticality(series: Mapping[str, Any]) -> dict[str, float | None]:
    """The four numbers of one record's ``series`` (rounded to 0.01; None where unmeasured)."""
    times = _floats(series.get("t"))
    closing = [_pair_numbers(series, role, times) for role in _partners(series)]
    ttc = [value for pair in closing for value in pair[0]]
    thw = [value for pair in closing for value in pair[1]]
    brakes = [hardest_braking(times, _floats(series.get(f"{role}_speed_raw_ms")),
                              _noise(series, role, len(times)))
              for role in EVENT_ROLES if f"{role}_speed_raw_ms" in series]
    swerves = [lateral_peak(times, _floats(series.get(f"{role}_lateral_m")),
                            _noise(series, role, len(times)))
               for role in EVENT_ROLES if f"{role}_lateral_m" in series]
    return {"ttc_min_s": _rounded(min(ttc, default=None)),
            "thw_min_s": _rounded(min(thw, default=None)),
            "brake_1s_max_ms2": _rounded(_largest(brakes)),
            "lat_acc_peak_ms2": _rounded(_largest(swerves))}


def hardest_braking(t: Floats, speed: Floats, noise: Mask) -> float | None:
    """The largest mean deceleration over any :data:`WINDOW_S` window of ``speed`` whose
    samples are all known and free of noise (0 when it never slows; None: no such window)."""
    best: float | None = None
    usable = np.isfinite(speed) & ~noise
    for i in range(len(t)):
        j = int(np.searchsorted(t, t[i] + WINDOW_S - 1e-6))
        if j >= len(t):
            break
        if usable[i:j + 1].all() and t[j] - t[i] > 0:
            loss = float((speed[i] - speed[j]) / (t[j] - t[i]))
            best = max(best if best is not None else 0.0, loss, 0.0)
    return best


def lateral_peak(t: Floats, lateral: Floats, noise: Mask) -> float | None:
    """The largest |second difference| of ``lateral`` over +-half a window, at the steps
    where the three samples are known and free of noise (None where there is no such step)."""
    half = WINDOW_S / 2
    best: float | None = None
    usable = np.isfinite(lateral) & ~noise
    for i in range(len(t)):
        before = int(np.searchsorted(t, t[i] - half - 1e-6))
        after = int(np.searchsorted(t, t[i] + half - 1e-6))
        if after >= len(t) or abs(t[i] - t[before] - half) > 0.05 \
                or abs(t[after] - t[i] - half) > 0.05:
            continue
        if not usable[before:after + 1].all():
            continue
        h1, h2 = t[i] - t[before], t[after] - t[i]
        slope = (lateral[after] - lateral[i]) / h2 - (lateral[i] - lateral[before]) / h1
        value = abs(float(2 * slope / (h1 + h2)))
        best = value if best is None else max(best, value)
    return best


def _pair_numbers(series: Mapping[str, Any], role: str,
                  times: Floats) -> tuple[list[float], list[float]]:
    """Times to collision and time headways between the ego and ``role`` at every step the
    two share a lane, are apart along it and neither is tracking noise."""
    n = len(times)
    gap = _floats(series.get(f"{role}_gap_m"), n)
    ego_v = _floats(series.get("ego_speed_raw_ms"), n)
    other_v = _floats(series.get(f"{role}_speed_raw_ms"), n)
    same_lane = _floats(series.get("ego_lane"), n) == _floats(series.get(f"{role}_lane"), n)
    clean = ~_noise(series, "ego", n) & ~_noise(series, role, n)
    ok = same_lane & clean & np.isfinite(gap) & (gap != 0) & np.isfinite(ego_v) \
        & np.isfinite(other_v)
    ahead = gap > 0  # the other is the lead: the ego follows
    follower = np.where(ahead, ego_v, other_v)
    closing = follower - np.where(ahead, other_v, ego_v)
    distance = np.abs(gap)
    ttc = [float(d / c) for d, c in zip(distance[ok & (closing > 0)],
                                        closing[ok & (closing > 0)], strict=True)]
    moving = ok & (follower >= MOVING_MS)
    thw = [float(d / v) for d, v in zip(distance[moving], follower[moving], strict=True)]
    return ttc, thw


def _partners(series: Mapping[str, Any]) -> list[str]:
    """The series' roles with a gap to the ego (``npc``; a free ride's ``center``, ...)."""
    return [key.removesuffix("_gap_m") for key in series
            if key.endswith("_gap_m") and key != "ego_gap_m"]


def _floats(values: Any, n: int | None = None) -> Floats:
    """A series as floats, None as NaN; a missing or short one padded with NaN to ``n``."""
    if not isinstance(values, Sequence) or isinstance(values, str):
        values = []
    out = np.array([v if isinstance(v, int | float) and not isinstance(v, bool) else math.nan
                    for v in values], dtype=float)
    if n is not None and len(out) != n:
        out = np.concatenate([out[:n], np.full(max(n - len(out), 0), math.nan)])
    return out


def _noise(series: Mapping[str, Any], role: str, n: int) -> Mask:
    """Where the series marks ``role``'s samples as tracking noise (no mark: none)."""
    marks = _floats(series.get(f"{role}_noise"), n)
    return np.nan_to_num(marks, nan=0.0) > 0


def _largest(values: list[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return max(known) if known else None


def _rounded(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, 2)

"""Speeds and accelerations a detector can threshold: re-derived from the position along the
road and smoothed, because recorded speeds are noisy (NGSIM's differentiate to +-14 m/s^2)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from scenweave.mining.tracks import Floats, Mask, Track


@dataclass(frozen=True)
class Motion:
    """A track's smoothed longitudinal motion, one value per step."""

    speed: Floats
    acceleration: Floats


def smooth_motion(track: Track, window_s: float, noise: Mask | None = None) -> Motion:
    """Savitzky-Golay (order 2) derivatives of ``s`` over a centred window of ``window_s``;
    tracks shorter than a window, and a window under 5 steps (exact speeds, a replay's),
    keep their recorded speed, differentiated by steps. Where ``noise`` marks tracking noise
    (:class:`PositionsSpeed`), ``s`` is bridged across it first (linear in time between the
    clean samples either side): a detector's speed is then neither made of noise nor cut by
    it (issue 32: a brake out of a box's jump, or split in two by one)."""
    dt = _step(track.t)
    points = int(round(window_s / dt)) | 1 if dt > 0 else 1  # odd
    if len(track.t) < max(points, 5) or dt <= 0 or points < 5:
        speed = np.asarray(track.speed, dtype=float)
        return Motion(speed, np.gradient(speed, track.t) if len(speed) > 1 else speed * 0)
    s = bridged(track.t, np.asarray(track.s, dtype=float), noise)
    speed = savgol_filter(s, points, 2, deriv=1, delta=dt, mode="interp")
    accel = savgol_filter(s, points, 2, deriv=2, delta=dt, mode="interp")
    return Motion(np.clip(speed, 0.0, None), accel)


#: the speed fitted to and judged against: the positions' change (central differences of
#: ``s``), then a centred moving average over this long (s): the most smoothing allowed
POSITIONS_AVERAGE_S = 0.5
#: a change of speed faster than this between two steps is no car's (m/s^2) ...
NOISE_ACCELERATION_MS2 = 10.0
#: ... when the speed jumps back within this long (s): the tracker's box jumped, not the car
NOISE_RETURN_S = 2.0
#: the averaged speed (:data:`POSITIONS_AVERAGE_S`) of no car rises faster than this, or falls
#: faster than the other, m/s^2 (a hard brake is ~9; a strong start ~4)
NOISE_RISE_MS2, NOISE_FALL_MS2 = 6.0, 11.0
#: how a mined series' speeds were measured (``series["smoothing"]``, recorded.json)
SMOOTHING = {
    "speed_raw_ms": "speed from the recorded positions' change along the road (central "
                    f"differences), centred moving average over {POSITIONS_AVERAGE_S:g} s",
    "speed_ms": "the same series, tracking-noise samples left out (null): what phases are "
                "fitted to",
    "noise": f"1 where the positions' speed jumps faster than {NOISE_ACCELERATION_MS2:g} m/s^2 "
             f"and back within {NOISE_RETURN_S:g} s, or its {POSITIONS_AVERAGE_S:g} s average "
             f"rises faster than {NOISE_RISE_MS2:g} or falls faster than {NOISE_FALL_MS2:g} "
             f"m/s^2 (with the sag it snaps back from, up to {NOISE_RETURN_S:g} s): tracking "
             "noise, followed by no fit, bridged in what detectors threshold",
    "detection": "detectors threshold a 1 s Savitzky-Golay speed (mining/thresholds.json)",
}


@dataclass(frozen=True)
class PositionsSpeed:
    """A track's speed as its recorded positions give it, with the samples a tracker made
    up: what scenarios are fitted to and judged against (issue 31)."""

    #: positions' change, :data:`POSITIONS_AVERAGE_S` moving average (m/s)
    speed: Floats
    #: True where the speed jumps and returns faster than a car can (tracking noise)
    noise: Mask

    @property
    def fitted(self) -> Floats:
        """The speed with the noise left out (NaN): what phases follow."""
        return np.where(self.noise, np.nan, self.speed)

    @property
    def filled(self) -> Floats:
        """The speed with each noise sample taken from the nearest sample that is not: a
        record's fields, so that an event starting in noise starts at its series' first
        speed (all noise: as measured)."""
        clean = np.flatnonzero(~self.noise)
        if not len(clean) or not self.noise.any():
            return self.speed
        nearest = clean[np.abs(np.arange(len(self.speed))[:, None] - clean[None, :]).argmin(1)]
        return self.speed[nearest]


def positions_speed(t: Floats, s: Floats, recorded: Floats) -> PositionsSpeed:
    """The speed from the change of ``s`` (position along the road, or along an urban path;
    central differences, one-sided at the ends), averaged over a centred window of
    :data:`POSITIONS_AVERAGE_S` (shorter at the ends), and the samples of tracking noise in
    it. A track of one step keeps its ``recorded`` speed."""
    t, s = np.asarray(t, dtype=float), np.asarray(s, dtype=float)
    if len(t) < 2 or _step(t) <= 0:
        return PositionsSpeed(np.asarray(recorded, dtype=float), np.zeros(len(t), bool))
    raw = np.clip(np.gradient(s, t), 0.0, None)
    half = max(int(round(POSITIONS_AVERAGE_S / _step(t) / 2)), 0)
    kernel = np.ones(2 * half + 1)
    sums = np.convolve(np.pad(raw, half), kernel, mode="valid")
    counts = np.convolve(np.pad(np.ones(len(raw)), half), kernel, mode="valid")
    return PositionsSpeed(sums / counts, _noise(t, s, half))


def bridged(t: Floats, values: Floats, noise: Mask | None) -> Floats:
    """``values`` with the samples ``noise`` marks replaced by the line between the clean
    samples either side (held at the ends); unchanged without noise or without clean
    samples."""
    if noise is None or not noise.any() or noise.all():
        return values
    clean = ~noise
    return np.where(noise, np.interp(t, t[clean], values[clean]), values)


def _noise(t: Floats, s: Floats, half: int) -> Mask:
    """Tracking noise in the speed the positions give: :func:`_returning_jumps` (a jump
    and the jump back) and :func:`_impossible_changes` (a change no car makes)."""
    noise = _returning_jumps(t, s, half)
    if len(t) >= 3:
        noise |= _impossible_changes(t, s, half)
    return noise


def _impossible_changes(t: Floats, s: Floats, half: int) -> Mask:
    """Steps where the averaged speed rises faster than :data:`NOISE_RISE_MS2` or falls
    faster than :data:`NOISE_FALL_MS2` over :data:`POSITIONS_AVERAGE_S` (no car does), with
    the stretch such a change jumps back from: a speed that sagged (or swelled) for up to
    :data:`NOISE_RETURN_S` and then snaps back to where it was is the tracker's drift and
    snap, not a brake (18.0 -> 12.8 -> 23.7 m/s on US-101)."""
    raw = np.clip(np.gradient(s, t), 0.0, None)
    kernel = np.ones(2 * half + 1)
    speed = np.convolve(np.pad(raw, half, mode="edge"), kernel, mode="valid") / len(kernel)
    span = max(int(round(POSITIONS_AVERAGE_S / _step(t))), 1)
    noise = np.zeros(len(t), bool)
    for k in range(len(t) - span):
        change = (speed[k + span] - speed[k]) / (t[k + span] - t[k])
        if -NOISE_FALL_MS2 <= change <= NOISE_RISE_MS2:
            continue
        first = _sag_start(t, speed, k, rising=change > 0)
        noise[max(first - half, 0):min(k + span + half, len(t) - 1) + 1] = True
    return noise


def _sag_start(t: Floats, speed: Floats, k: int, rising: bool) -> int:
    """Where the sag (``rising``: the speed fell toward step ``k``) or swell that a snap at
    ``k`` jumps back from began: back from ``k`` while the speed kept falling (rising)
    toward it, at most :data:`NOISE_RETURN_S`."""
    first = k
    while first > 0 and t[k] - t[first - 1] <= NOISE_RETURN_S + 1e-6 \
            and (speed[first - 1] > speed[first] if rising else speed[first - 1] < speed[first]):
        first -= 1
    return first


def _returning_jumps(t: Floats, s: Floats, half: int) -> Mask:
    """Steps whose speed between positions jumps by more than a car can
    (:data:`NOISE_ACCELERATION_MS2`) and jumps back the other way within
    :data:`NOISE_RETURN_S`: everything from the jump to the return, widened by the moving
    average's half window (``half`` steps) it spreads into."""
    noise = np.zeros(len(t), bool)
    if len(t) < 3:
        return noise
    step_speed = np.diff(s) / np.diff(t)
    jumps = np.diff(step_speed) / (np.diff(t[:-1]) + np.diff(t[1:])) * 2
    hard = np.flatnonzero(np.abs(jumps) > NOISE_ACCELERATION_MS2)
    for k in hard:
        back = hard[(hard > k) & (t[hard + 1] - t[k + 1] <= NOISE_RETURN_S + 1e-6)
                    & (np.sign(jumps[hard]) != np.sign(jumps[k]))]
        if len(back):
            noise[max(k + 1 - half, 0):min(back[0] + 1 + half, len(t) - 1) + 1] = True
    return noise


def _step(t: Floats) -> float:
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def runs(mask: Mask) -> list[tuple[int, int]]:
    """``(first, last)`` step index of each run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


#: a bend of the road is only told apart from cars' own sideways motion where this many
#: cars drive it; with fewer, the road is taken as straight (its axis fitted)
MIN_TRACKS_FOR_BENDS = 8
#: the road's course is a broken line with a knot this often along ``s`` (m)
COURSE_KNOT_M = 20.0


def best_second_deceleration(t: Floats, speed: Floats, first: int, last: int,
                             trusted: Mask) -> float:
    """The most speed lost within one second between steps ``first`` and ``last`` (m/s^2):
    a brake shorter than a second counts with what it lost in it. Only ``trusted`` steps
    (where the smoothing window lies inside the track) are compared, so a fit at a track's
    end never passes for a brake."""
    steps = np.flatnonzero(trusted[first:last + 1]) + first
    if len(steps) < 2:
        return 0.0
    best = 0.0
    for k in steps:
        later = steps[(t[steps] > t[k]) & (t[steps] <= t[k] + 1.0 + 1e-6)]
        if len(later):
            best = max(best, float(speed[k] - speed[later].min()))
    return best


def trusted_steps(t: Floats, window_s: float) -> Mask:
    """Steps at least half a smoothing window from either end of the track."""
    half = window_s / 2 - 1e-6
    return (t - t[0] >= half) & (t[-1] - t >= half) if len(t) else np.zeros(0, bool)


def road_axis(tracks: list[Track]) -> Floats | None:
    """The unit vector along which ``s`` runs, fitted over every position of the recording
    (``s = axis . (x, y)`` on a road of one direction); None where no single axis fits."""
    xy = np.concatenate([np.column_stack([tr.x, tr.y]) for tr in tracks]) if tracks else None
    if xy is None or len(xy) < 3:
        return None
    s = np.concatenate([tr.s for tr in tracks])
    axis, *_ = np.linalg.lstsq(np.column_stack([xy, np.ones(len(xy))]), s, rcond=None)
    fitted = np.column_stack([xy, np.ones(len(xy))]) @ axis
    if abs(np.hypot(*axis[:2]) - 1) > 0.01 or np.sqrt(np.mean((fitted - s) ** 2)) > 0.5:
        return None
    return axis[:2] / np.hypot(*axis[:2])


def lateral_offsets(tracks: list[Track]) -> list[Floats]:
    """Each track's lateral position (m, + to the left of the direction of travel) measured
    from the road's own course: a gentle bend moves every lane alike, so one smooth curve in
    ``s`` plus a lane width per lane index is fitted through every car's position (cars off
    it, between lanes or on a ramp, trimmed) and the curve removed; what remains moves only
    when a car moves across the road. A reader's own ``Track.lateral`` wins; NaN where
    neither is known (no single road axis: lanes are then all a detector knows)."""
    if tracks and all(len(tr.lateral) == len(tr.t) for tr in tracks):
        return [np.asarray(tr.lateral, dtype=float) for tr in tracks]
    axis = road_axis(tracks)
    if axis is None:
        return [np.full(len(tr.t), np.nan) for tr in tracks]
    normal = np.array([-axis[1], axis[0]])
    lat = [np.column_stack([tr.x, tr.y]) @ normal for tr in tracks]
    s_all = np.concatenate([tr.s for tr in tracks])
    lane_all = np.concatenate([_lane_numbers(tr) for tr in tracks])
    bends = len(tracks) >= MIN_TRACKS_FOR_BENDS
    course = _road_course(s_all, np.concatenate(lat), lane_all, bends)
    return [v - course(tr.s) for v, tr in zip(lat, tracks, strict=True)]


#: lanes' centres closer than this are no lanes the lateral positions tell apart (m)
MIN_LANE_SPACING_M = 2.0


def lane_spacing(tracks: list[Track], lateral: list[Floats]) -> float | None:
    """How far apart lane centres lie in :func:`lateral_offsets`' terms: the centre of lane
    index ``k`` is at ``spacing * k`` (negative: indexes grow to the right, offsets to the
    left). The median over every step with a lane index and a lateral position; None where
    no step has both, or the lanes come out closer than :data:`MIN_LANE_SPACING_M`."""
    ratios = [np.asarray(lat, dtype=float) / _lane_numbers(tr)
              for tr, lat in zip(tracks, lateral, strict=True)]
    found = np.concatenate(ratios) if ratios else np.empty(0)
    found = found[np.isfinite(found)]
    spacing = float(np.median(found)) if len(found) else 0.0
    return spacing if abs(spacing) >= MIN_LANE_SPACING_M else None  # lanes not told apart


def _road_course(s: Floats, lat: Floats, lane: Floats, bends: bool,
                 rounds: int = 4) -> Callable[[Floats], Floats]:
    """``lat ~ course(s) - width * lane``: the course a broken line with a knot every
    :data:`COURSE_KNOT_M` (``bends``) or one constant, refitted without the points further
    off than twice the median residual; returns the course."""
    knots = np.arange(np.min(s), np.max(s) + COURSE_KNOT_M, COURSE_KNOT_M) if bends \
        else np.array([float(np.min(s))])
    known = np.isfinite(lane)
    design = np.column_stack([_hats(s, knots), np.where(known, lane, 0.0)])
    keep = known if known.sum() >= design.shape[1] else np.ones(len(s), bool)
    coefficients = np.zeros(design.shape[1])
    for _ in range(rounds):
        coefficients, *_ = np.linalg.lstsq(design[keep], lat[keep], rcond=None)
        residual = np.abs(design @ coefficients - lat)
        trimmed = keep & (residual <= max(2 * float(np.median(residual[keep])), 0.05))
        if trimmed.sum() < design.shape[1] or trimmed.sum() == keep.sum():
            break
        keep = trimmed
    return lambda at: _hats(np.asarray(at, dtype=float), knots) @ coefficients[:-1]


def _hats(s: Floats, knots: Floats) -> Floats:
    """Piecewise-linear basis: one column per knot, 1 at it, falling to 0 at its
    neighbours (flat beyond the ends); a single knot is a constant."""
    if len(knots) == 1:
        return np.ones((len(s), 1))
    columns = [np.interp(s, knots, np.eye(len(knots))[k]) for k in range(len(knots))]
    return np.column_stack(columns)


def _lane_numbers(track: Track) -> Floats:
    index = np.asarray(track.lane_index, dtype=float)
    return index if len(index) == len(track.t) else np.full(len(track.t), np.nan)

"""Speeds and accelerations a detector can threshold: re-derived from the position along the
road and smoothed, because recorded speeds are noisy (NGSIM's differentiate to +-14 m/s^2)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from scenweave.mining.tracks import Track


@dataclass(frozen=True)
class Motion:
    """A track's smoothed longitudinal motion, one value per step."""

    speed: np.ndarray
    acceleration: np.ndarray


def smooth_motion(track: Track, window_s: float) -> Motion:
    """Savitzky-Golay (order 2) derivatives of ``s`` over a centred window of ``window_s``;
    tracks shorter than a window keep their recorded speed, differentiated by steps."""
    dt = _step(track.t)
    points = int(round(window_s / dt)) | 1  # odd
    if len(track.t) < max(points, 5) or dt <= 0:
        speed = np.asarray(track.speed, dtype=float)
        return Motion(speed, np.gradient(speed, track.t) if len(speed) > 1 else speed * 0)
    s = np.asarray(track.s, dtype=float)
    speed = savgol_filter(s, points, 2, deriv=1, delta=dt, mode="interp")
    accel = savgol_filter(s, points, 2, deriv=2, delta=dt, mode="interp")
    return Motion(np.clip(speed, 0.0, None), accel)


def _step(t: np.ndarray) -> float:
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(first, last)`` step index of each run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))

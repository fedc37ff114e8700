"""Recordings made from physics, for detection tests: cars on a straight road, lanes indexed
from the left, 0.1 s steps."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from scenweave.mining import Recording, Track
from scenweave.mining.detect import detect
from scenweave.mining.thresholds import load_thresholds

DT = 0.1


def car(track_id: str, duration_s: float, s0: float, speed: Callable[[np.ndarray], np.ndarray],
        lane: Callable[[np.ndarray], np.ndarray] | int, length_m: float = 4.5,
        vehicle_type: str = "car") -> Track:
    """A car starting at ``s0``; ``speed(t)`` in m/s, integrated for ``s``."""
    t = np.round(np.arange(0.0, duration_s + DT / 2, DT), 3)
    v = speed(t)
    s = s0 + np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2 * DT)])
    lanes = np.full(len(t), float(lane)) if isinstance(lane, int) else lane(t).astype(float)
    return Track(id=track_id, length_m=length_m, width_m=1.8, vehicle_type=vehicle_type, t=t,
                 x=s, y=-3.5 * lanes, heading=np.zeros(len(t)), speed=v, s=s,
                 lane=np.array([str(int(k)) for k in lanes], dtype=object), lane_index=lanes)


def steady(v: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda t: np.full(len(t), v)


def braking(v0: float, from_s: float, decel: float,
            v1: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda t: np.clip(v0 - decel * np.clip(t - from_s, 0, None), v1, None)


def switch(first: int, second: int, at_s: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda t: np.where(t < at_s, first, second)


def recording(*tracks: Track, source: str = "synthetic") -> Recording:
    return Recording(source=source, dt=DT, tracks=list(tracks), reader="synthetic")


def profile(*points: tuple[float, float]) -> Callable[[np.ndarray], np.ndarray]:
    """A value through ``(time, value)`` points, linear in between (a speed, a lane)."""
    times, values = zip(*points, strict=True)
    return lambda t: np.interp(t, times, values)


def events_by_code(rec: Recording) -> dict[str, list]:
    """What the detectors find in ``rec`` with the shipped thresholds, by class code."""
    found: dict[str, list] = {}
    for event in detect(rec, load_thresholds()):
        found.setdefault(event.code, []).append(event)
    return found

"""Helpers the highway sample generators share: how MOOVE files spell choices and vehicles."""

from __future__ import annotations

import numpy as np

KMH = 3.6
Columns = dict[str, np.ndarray]
VEHICLE_TYPES = np.array(["Car", "Truck", "Van", "Motorcycle"], dtype=object)
VEHICLE_WEIGHTS = [0.78, 0.14, 0.06, 0.02]


def yes_no(rng: np.random.Generator, n: int, p_yes: float = 0.6) -> np.ndarray:
    return np.where(rng.random(n) < p_yes, "Yes", "No").astype(object)


def left_right(rng: np.random.Generator, n: int, p_left: float = 0.55) -> np.ndarray:
    return np.where(rng.random(n) < p_left, "Left", "Right").astype(object)


def vehicle_types(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.choice(VEHICLE_TYPES, size=n, p=VEHICLE_WEIGHTS)


def speeds_kmh(rng: np.random.Generator, n: int, low: float, high: float) -> np.ndarray:
    return np.round(rng.uniform(low, high, n), 1)

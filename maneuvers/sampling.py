"""Helpers the highway sample generators share: how MOOVE files spell choices and vehicles."""

from __future__ import annotations

import zlib

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


#: the classes whose sample data was seeded by their position before classes could be added
#: (highway, then urban, each by code): they keep those streams, so the sample data and every
#: scenario made from it stay byte for byte what they were
POSITION_SEEDED = {"highway": ("BRAKE", "BR_BK", "CINB", "CINF", "COUTB", "COUTF", "FLB", "FLF",
                               "FRB", "FRF", "LCB", "LCF"),
                   "urban": ("U1_1", "U4_1", "U4_2", "U4_3", "U4_4")}
#: where the urban classes' positions start
URBAN_POSITION_BASE = 100


def sample_stream(seed: int, code: str, *more: int) -> np.random.Generator:
    """The random stream a class's sample data is drawn from: its own, so adding a class
    (built in or a plugin) never changes another class's rows. The classes of
    :data:`POSITION_SEEDED` keep their position; any other is keyed by its code."""
    for domain, base in (("highway", 0), ("urban", URBAN_POSITION_BASE)):
        if code in POSITION_SEEDED[domain]:
            return np.random.default_rng([seed, base + POSITION_SEEDED[domain].index(code), *more])
    return np.random.default_rng([seed, 1 << 32 | zlib.crc32(code.encode()), *more])

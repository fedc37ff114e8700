"""Ego lane changes (LCF, LCB)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from scenweave.maneuvers.maneuver import Conventions, Maneuver, ParamsPart, Row
from scenweave.maneuvers.sampling import (
    KMH,
    Columns,
    left_right,
    speeds_kmh,
    yes_no,
)

LAYOUT_FIELDS = ("ego_vel_begin_kmh", "ego_vel_end_kmh", "duration_s", "other_dir_traffic",
                 "direction")


def extract(raw: Row, code: str, conventions: Conventions) -> ParamsPart:
    return {
        "ego_speed_ms": raw["ego_vel_begin_kmh"] / KMH,
        "ego_end_speed_ms": raw["ego_vel_end_kmh"] / KMH,
        "lane_change_direction": raw["direction"].lower(),
    }


def sample(rng: np.random.Generator, n: int, code: str) -> Columns:
    begin = speeds_kmh(rng, n, 95, 135)
    end = np.round(begin + rng.normal(2.5 if code == "LCF" else 1.0, 2.0, n), 1)
    duration = np.round(np.clip(rng.normal(4.0, 0.6, n), 2.5, 6.0), 1)
    return {"ego_vel_begin_kmh": begin, "ego_vel_end_kmh": end, "duration_s": duration,
            "other_dir_traffic": yes_no(rng, n, 0.3), "direction": left_right(rng, n)}


def target_side(params: Mapping[str, Any]) -> list[str]:
    """The ego moves towards ``lane_change_direction``: that lane must exist."""
    return [params["lane_change_direction"]]


MANEUVERS = tuple(
    Maneuver(code=code, tag=tag, domain="highway", name=name,
             script=f"gen_hw_{code.lower()}.py", layout_fields=LAYOUT_FIELDS,
             extract=extract, sample=sample, lane_sides=target_side, lane_change="hero")
    for code, tag, name in (("LCF", "lane_change_front", "Ego changes lane (front view)"),
                            ("LCB", "lane_change_behind", "Ego changes lane (rear view)")))

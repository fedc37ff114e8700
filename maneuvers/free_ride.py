"""Free rides (FRF, FRB): the ego drives on, with up to three surrounding vehicles in front
of it (FRF) or behind it (FRB), one per slot: its own lane (center) and the lanes beside it.

The slots' 'absent' sentinels are the layout's (``ClassLayout.conventions["sentinels"]``:
column name -> values that mean 'no vehicle'), so canonicalisation (``has_npc``) and
extraction (the ``slot_*`` params) decide presence with one function and the same values.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from scenweave.maneuvers.maneuver import (
    Conventions,
    Maneuver,
    NpcPosition,
    ParamsPart,
    Row,
    SameLane,
)
from scenweave.maneuvers.sampling import KMH, Columns, speeds_kmh, vehicle_types, yes_no

SLOTS = ("center", "right", "left")
LAYOUT_FIELDS = ("ego_vel_begin_kmh", "ego_vel_end_kmh", "ego_dist_traveled_m", "duration_s",
                 *(f"{slot}_{what}" for slot in SLOTS
                   for what in ("posx_begin_m", "posx_end_m", "vel_begin_ms", "vel_end_ms",
                                "vehicle_type")))
Sentinels = Mapping[str, Sequence[float]]


def is_sentinel(params: Mapping[str, Any], field: str, sentinels: Sentinels) -> bool:
    """The value of ``field`` is one of the layout's 'absent' markers for that column."""
    return params[field] in sentinels.get(field, ())


def slot_present(params: Mapping[str, Any], slot: str, sentinels: Sentinels) -> bool:
    """A slot holds a vehicle unless its start position or start speed is a sentinel
    (or its vehicle type says ``None``)."""
    if is_sentinel(params, f"{slot}_posx_begin_m", sentinels):
        return False
    if is_sentinel(params, f"{slot}_vel_begin_ms", sentinels):
        return False
    return params.get(f"{slot}_vehicle_type") != "None"


def slot_params(params: Mapping[str, Any], slot: str, sign: float,
                sentinels: Sentinels) -> ParamsPart:
    """The ``<slot>_*`` params of one slot: SI values, distances signed ``sign`` (+1 ahead,
    -1 behind); an absent slot gives present false, 0.0 and None. A present vehicle whose end
    value is a sentinel (it left the sensor's range) keeps its start value."""
    if not slot_present(params, slot, sentinels):
        return {f"{slot}_present": False, f"{slot}_speed_ms": 0.0, f"{slot}_end_speed_ms": 0.0,
                f"{slot}_distance_m": 0.0, f"{slot}_end_distance_m": 0.0,
                f"{slot}_vehicle_type": None}

    def end_or_start(what: str) -> float:
        end = f"{slot}_{what}_end_{'m' if what == 'posx' else 'ms'}"
        start = end.replace("_end_", "_begin_")
        value: float = params[start] if is_sentinel(params, end, sentinels) else params[end]
        return value

    return {
        f"{slot}_present": True,
        f"{slot}_speed_ms": params[f"{slot}_vel_begin_ms"],
        f"{slot}_end_speed_ms": end_or_start("vel"),
        f"{slot}_distance_m": sign * abs(params[f"{slot}_posx_begin_m"]),
        f"{slot}_end_distance_m": sign * abs(end_or_start("posx")),
        f"{slot}_vehicle_type": str(params[f"{slot}_vehicle_type"]).lower(),
    }


def extract(raw: Row, code: str, conventions: Conventions) -> ParamsPart:
    params: ParamsPart = {
        "ego_speed_ms": raw["ego_vel_begin_kmh"] / KMH,
        "ego_end_speed_ms": raw["ego_vel_end_kmh"] / KMH,
        "ego_dist_traveled_m": raw["ego_dist_traveled_m"],
    }
    if code == "FRF":
        params["driving_side"] = str(raw.get("driving_side", "Right")).lower()
    sign = -1.0 if code == "FRB" else 1.0
    sentinels = conventions.get("sentinels", {})
    for slot in SLOTS:
        params.update(slot_params(raw, slot, sign, sentinels))
    return params


def sample(rng: np.random.Generator, n: int, code: str) -> Columns:
    behind = code == "FRB"
    duration = np.round(rng.uniform(4.0, 20.0, n), 1)
    ego0 = speeds_kmh(rng, n, 80, 135)
    ego1 = np.round(ego0 + rng.normal(0, 3, n), 1)
    columns: Columns = {
        "ego_vel_begin_kmh": ego0, "ego_vel_end_kmh": ego1,
        "ego_dist_traveled_m": np.round((ego0 + ego1) / 2 / 3.6 * duration, 1),
        "ego_acc_mean_ms2": np.round((ego1 - ego0) / 3.6 / duration, 3),
        "duration_s": duration, "ego_lane_index": rng.integers(1, 4, n).astype(float),
        "lane_count": np.full(n, 4.0), "ego_lat_offset_m": np.round(rng.normal(0, 0.2, n), 2),
        "speed_limit_kmh": np.full(n, 130.0),
        "driving_side": np.full(n, "Right", dtype=object),
        "other_dir_traffic": yes_no(rng, n),
    }
    for slot, p_present in (("center", 0.7), ("right", 0.5), ("left", 0.5)):
        columns.update(_slot(rng, n, slot, p_present, ego0, ego1, duration, behind))
    if n >= 1:  # edge row: nobody around, every slot a sentinel (position -1, speed -3.6)
        for slot in ("center", "right", "left"):
            for key, value in (("posx_begin_m", -1.0), ("posx_end_m", -1.0),
                               ("vel_begin_ms", -3.6), ("vel_end_ms", -3.6)):
                columns[f"{slot}_{key}"][0] = value
            columns[f"{slot}_vehicle_type"][0] = "None"
    return columns


def _slot(rng: np.random.Generator, n: int, slot: str, p_present: float, ego0_kmh: np.ndarray,
          ego1_kmh: np.ndarray, duration: np.ndarray, behind: bool) -> Columns:
    present = rng.random(n) < p_present
    sign = -1 if behind else 1
    ego0, ego1 = ego0_kmh / 3.6, ego1_kmh / 3.6
    # the slot's speed relative to the ego keeps its sign over the record, so the gap only
    # grows or only shrinks (both change speed linearly), and it ends no closer than 10 m: the
    # end gap follows from the speeds and no car drives through the ego's
    rel0 = np.clip(ego0 + rng.normal(0, 2.5, n), 5, None) - ego0
    rel1 = rel0 + rng.normal(0, 0.5, n)
    rel1 = np.where(np.sign(rel1) == np.sign(rel0), rel1, 0.0)
    gap0 = rng.uniform(15, 90, n)
    closing = -sign * (rel0 + rel1) / 2
    limit = (gap0 - 10.0) / duration
    scale = np.where(closing > limit, limit / np.where(closing > 0, closing, 1.0), 1.0)
    rel0, rel1 = rel0 * scale, rel1 * scale
    speed0, speed1 = ego0 + rel0, ego1 + rel1
    gap1 = gap0 + sign * (rel0 + rel1) / 2 * duration
    absent_speed = rng.choice([-3.6, -1.0], n)
    return {
        f"{slot}_posx_begin_m": np.where(present, np.round(sign * gap0, 1), -1.0),
        f"{slot}_posx_end_m": np.where(present, np.round(sign * gap1, 1), -1.0),
        f"{slot}_vel_begin_ms": np.where(present, np.round(speed0, 2), absent_speed),
        f"{slot}_vel_end_ms": np.where(present, np.round(speed1, 2), absent_speed),
        f"{slot}_vehicle_type": np.where(present, vehicle_types(rng, n), "None").astype(object),
    }


_CLASSES: tuple[tuple[str, str, str, NpcPosition], ...] = (
    ("FRF", "free_ride_front", "Free ride, traffic in front", "front"),
    ("FRB", "free_ride_behind", "Free ride, traffic behind", "behind"))


def present_sides(params: Mapping[str, Any]) -> list[str]:
    """The neighbour lanes that hold a surrounding vehicle."""
    return [side for side in ("left", "right") if params.get(f"{side}_present")]


MANEUVERS = tuple(
    Maneuver(code=code, tag=tag, domain="highway", name=name,
             script=f"gen_hw_{code.lower()}.py", layout_fields=LAYOUT_FIELDS,
             extract=extract, sample=sample, npc_position=position, lane_sides=present_sides,
             surrounding_slots=True,
             same_lane=SameLane("center", "center_posx_begin_m", "all_along"))
    for code, tag, name, position in _CLASSES)

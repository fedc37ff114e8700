"""Car following (FLF: the ego follows a lead; FLB: a car follows the ego)."""

from __future__ import annotations

import numpy as np

from scenweave.maneuvers.maneuver import (
    Conventions,
    Maneuver,
    NpcPosition,
    ParamsPart,
    Row,
    SameLane,
)
from scenweave.maneuvers.sampling import (
    KMH,
    Columns,
    speeds_kmh,
    vehicle_types,
    yes_no,
)

LAYOUT_FIELDS = ("ego_vel_begin_kmh", "ego_vel_end_kmh", "lead_vel_begin_kmh", "lead_vel_end_kmh",
                 "npc_distance_begin_m", "npc_distance_end_m", "lead_dist_traveled_m",
                 "duration_s", "other_dir_traffic", "behavior_type", "lead_vehicle_type")


def extract(raw: Row, code: str, conventions: Conventions) -> ParamsPart:
    sign = -1.0 if code == "FLB" else 1.0
    return {
        "ego_speed_ms": raw["ego_vel_begin_kmh"] / KMH,
        "ego_end_speed_ms": raw["ego_vel_end_kmh"] / KMH,
        "npc_speed_ms": raw["lead_vel_begin_kmh"] / KMH,
        "npc_end_speed_ms": raw["lead_vel_end_kmh"] / KMH,
        "npc_distance_m": sign * abs(raw["npc_distance_begin_m"]),
        "npc_distance_end_m": sign * abs(raw["npc_distance_end_m"]),
        "npc_dist_traveled_m": raw["lead_dist_traveled_m"],
        "behavior_type": raw["behavior_type"],
        "npc_vehicle_type": raw["lead_vehicle_type"].lower(),
    }


def sample(rng: np.random.Generator, n: int, code: str) -> Columns:
    behaviour = rng.choice(np.array(["B1", "B2", "B3", "B4"], dtype=object), n,
                           p=[0.25, 0.25, 0.35, 0.15])
    duration = np.round(rng.uniform(2.0, 10.0, n), 1)
    ego0 = speeds_kmh(rng, n, 50, 130)
    closing = np.select([behaviour == "B1", behaviour == "B2"],
                        [rng.uniform(-12, -3, n), rng.uniform(3, 12, n)], rng.normal(0, 1, n))
    # B1/B2: the initial speed difference already points the way the gap goes
    offset = np.where(np.isin(behaviour, ["B1", "B2"]), -np.sign(closing) * np.abs(
        rng.normal(0, 1.5, n)), rng.normal(0, 2, n))
    lead0 = ego0 + offset
    lead1 = lead0 - closing / 2
    ego1 = ego0 + closing / 2
    gap0 = np.where(behaviour == "B4", rng.uniform(55, 110, n),
                    np.clip(ego0 / 3.6 * rng.uniform(0.8, 2.0, n), 8, 49))
    mean_rel_ms = ((ego0 + ego1) - (lead0 + lead1)) / 2 / 3.6
    # an ego faster than the other car closes in on it ahead (FLF) and draws away from it
    # behind (FLB): the end gap follows from the speeds, or no replay can show both; where
    # the drawn speeds would bring the cars closer than 5 m, the other car's end speed gives way
    closes_in = 1.0 if code == "FLF" else -1.0
    shrinking_ms = np.minimum(closes_in * mean_rel_ms, (gap0 - 5.0) / duration)
    mean_rel_ms = closes_in * shrinking_ms
    lead1 = (ego0 + ego1) - mean_rel_ms * 3.6 * 2 - lead0
    gap1 = gap0 - closes_in * mean_rel_ms * duration
    travelled = (lead0 + lead1) / 2 / 3.6 * duration
    return {"ego_vel_begin_kmh": np.round(ego0, 1), "ego_vel_end_kmh": np.round(ego1, 1),
            "lead_vel_begin_kmh": np.round(lead0, 1), "lead_vel_end_kmh": np.round(lead1, 1),
            "npc_distance_begin_m": np.round(gap0, 1), "npc_distance_end_m": np.round(gap1, 1),
            "lead_dist_traveled_m": np.round(travelled, 1), "duration_s": duration,
            "other_dir_traffic": yes_no(rng, n), "behavior_type": behaviour,
            "lead_vehicle_type": vehicle_types(rng, n)}


#: a phased row's lead dips this much (km/h) below its ramp half way through
PHASED_DIP_KMH = (8.0, 20.0)
#: a phased row's gap never comes closer than this (m, bumpers)
PHASED_CLOSEST_M = 8.0


def sample_phased(rng: np.random.Generator, n: int, code: str) -> Columns:
    """Rows whose end gap no single ramp of the other car reaches: it slows down in between
    and catches up again (a dip of 8-20 km/h half way), so its record needs two phases."""
    rows = sample(rng, n, code)
    duration = rows["duration_s"]
    loss = np.round(rng.uniform(*PHASED_DIP_KMH, n) / KMH / 2 * duration, 1)
    begin, end = rows["npc_distance_begin_m"], rows["npc_distance_end_m"]
    if code == "FLF":  # the lead falls back toward the ego: room for it first
        shift = np.maximum(PHASED_CLOSEST_M + loss - np.minimum(begin, end), 0.0)
        begin, end = begin + shift, end + shift - loss
    else:  # the car behind falls further back
        end = end + loss
    return {**rows, "npc_distance_begin_m": np.round(begin, 1),
            "npc_distance_end_m": np.round(end, 1),
            "lead_dist_traveled_m": np.round(rows["lead_dist_traveled_m"] - loss, 1)}


_CLASSES: tuple[tuple[str, str, str, NpcPosition], ...] = (
    ("FLF", "follow_front", "Ego follows a lead vehicle", "front"),
    ("FLB", "follow_behind", "A vehicle follows the ego", "behind"))

MANEUVERS = tuple(
    Maneuver(code=code, tag=tag, domain="highway", name=name,
             script=f"gen_hw_{code.lower()}.py", layout_fields=LAYOUT_FIELDS,
             extract=extract, sample=sample, sample_phased=sample_phased,
             npc_position=position,
             same_lane=SameLane("npc", "npc_distance_begin_m", "all_along"),
             npc_speed_change=True, gap_at_end=True)
    for code, tag, name, position in _CLASSES)

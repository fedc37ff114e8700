"""Lead vehicle braking (BRAKE, BR_BK: the same manoeuvre, BR_BK in busier traffic)."""

from __future__ import annotations

import numpy as np

from scenweave.maneuvers.maneuver import (
    Conventions,
    Maneuver,
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

LAYOUT_FIELDS = ("ego_vel_kmh", "lead_vel_kmh", "duration_s", "delta_vel_kmh", "npc_distance_m",
                 "brake_intensity", "other_dir_traffic", "lead_vehicle_type")


def extract(raw: Row, code: str, conventions: Conventions) -> ParamsPart:
    return {
        "ego_speed_ms": raw["ego_vel_kmh"] / KMH,
        "npc_speed_ms": raw["lead_vel_kmh"] / KMH,
        "delta_speed_ms": raw["delta_vel_kmh"] / KMH,
        "npc_distance_m": raw["npc_distance_m"],
        "brake_intensity": raw["brake_intensity"],
        "npc_vehicle_type": raw["lead_vehicle_type"].lower(),
    }


def sample(rng: np.random.Generator, n: int, code: str) -> Columns:
    busy = code == "BR_BK"
    ego = speeds_kmh(rng, n, 40 if busy else 60, 120 if busy else 135)
    lead = np.clip(np.round(ego + rng.normal(-4, 5, n), 1), 5, None)
    intensity = np.round(rng.beta(2, 4, n), 2)
    duration = np.round(np.clip(rng.lognormal(0.6, 0.45, n), 0.3, 8), 1)
    delta = -np.round(intensity * 8.0 * duration * 3.6 * rng.uniform(0.5, 1.0, n), 2)
    headway = rng.uniform(0.7, 2.5, n)
    distance = np.round(np.clip(ego / 3.6 * headway, 5, 120), 1)
    if n >= 2:  # edge rows: the lead brakes to a standstill (lead + delta < 0); shortest burst
        delta[0], intensity[0] = -(lead[0] + 15.0), 1.0
        duration[0] = max(duration[0], np.ceil(lead[0] / 3.6 / 8.0 * 10) / 10)  # <= 8 m/s^2
        duration[1], delta[1] = 0.1, -0.08
    return {"ego_vel_kmh": ego, "lead_vel_kmh": lead, "duration_s": duration,
            "delta_vel_kmh": delta, "npc_distance_m": distance, "brake_intensity": intensity,
            "other_dir_traffic": yes_no(rng, n), "lead_vehicle_type": vehicle_types(rng, n)}


def _brake_class(code: str, name: str) -> Maneuver:
    return Maneuver(
        code=code, tag="brake", domain="highway", name=name, script="gen_hw_brake.py",
        layout_fields=LAYOUT_FIELDS, extract=extract, sample=sample,
        ego_end_speed_factor=1.0, npc_position="front",
        same_lane=SameLane("npc", "npc_distance_m", "at_start"),
        npc_speed_change=True, lead_brakes=True, ego_reacts="from_start")


MANEUVERS = (_brake_class("BRAKE", "Lead vehicle brakes"),
             _brake_class("BR_BK", "Lead vehicle brakes in busy traffic"))

"""A toy manoeuvre class, added from outside ScenWeave's code: ACCEL, the lead speeds away.

Everything ScenWeave needs to know of the class is here (its layout, how a row becomes params,
its sample rows, where its NPC starts, what the checks look for) plus its reference script
next to this file. Load it with ``SCENWEAVE_PLUGINS=/path/to/accel.py`` (docs/plugins.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenweave.maneuvers import Maneuver, SameLane

KMH = 3.6
LAYOUT = {
    "gaps_between": "reference_points",
    "columns": [
        {"name": "ego_vel_kmh", "kind": "number", "unit": "km/h", "min": 0},
        {"name": "lead_vel_kmh", "kind": "number", "unit": "km/h", "min": 0},
        {"name": "lead_end_vel_kmh", "kind": "number", "unit": "km/h", "min": 0},
        {"name": "duration_s", "kind": "number", "unit": "s", "min": 0.1},
        {"name": "npc_distance_m", "kind": "number", "unit": "m", "min": 0},
        {"name": "lead_vehicle_type", "kind": "enum", "values": ["Car", "Van"]},
    ],
}


def extract(raw, code, conventions) -> dict:
    return {"ego_speed_ms": raw["ego_vel_kmh"] / KMH, "npc_speed_ms": raw["lead_vel_kmh"] / KMH,
            "npc_end_speed_ms": raw["lead_end_vel_kmh"] / KMH,
            "npc_distance_m": raw["npc_distance_m"],
            "npc_vehicle_type": raw["lead_vehicle_type"].lower()}


def sample(rng: np.random.Generator, n: int, code: str) -> dict[str, np.ndarray]:
    ego = np.round(rng.uniform(70, 100, n), 1)
    lead = np.round(ego + rng.uniform(0, 5, n), 1)
    return {"ego_vel_kmh": ego, "lead_vel_kmh": lead,
            "lead_end_vel_kmh": np.round(lead + rng.uniform(10, 20, n), 1),
            "duration_s": np.round(rng.uniform(3, 6, n), 1),
            "npc_distance_m": np.round(rng.uniform(30, 50, n), 1),
            "lead_vehicle_type": np.array(["Car"] * n, dtype=object)}


MANEUVERS = (
    Maneuver(code="ACCEL", tag="lead_accelerates", domain="highway",
             name="Lead vehicle speeds away",
             script=str(Path(__file__).with_name("gen_hw_accel.py")),
             layout_fields=tuple(c["name"] for c in LAYOUT["columns"]),
             layout=LAYOUT, extract=extract, sample=sample, ego_end_speed_factor=1.0,
             npc_position="front", same_lane=SameLane("npc", "npc_distance_m", "at_start"),
             npc_speed_change=True),
)

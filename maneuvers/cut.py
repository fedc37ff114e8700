"""Cut-ins and cut-outs (CINF, CINB, COUTF, COUTB): an NPC changes lane into or out of the
ego's lane, in front of it or behind it."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from scenweave.maneuvers.maneuver import (
    Conventions,
    Maneuver,
    ParamsPart,
    RecordFieldError,
    Row,
    SameLane,
)
from scenweave.maneuvers.sampling import (
    KMH,
    Columns,
    left_right,
    speeds_kmh,
    vehicle_types,
    yes_no,
)

LAYOUT_FIELDS = ("ego_vel_kmh", "cutter_vel_kmh", "delta_vel_kmh", "duration_s", "npc_distance_m",
                 "other_dir_traffic", "direction", "lead_vehicle_type")


def extract(raw: Row, code: str, conventions: Conventions) -> ParamsPart:
    try:
        sign = float(conventions["relative_speed_sign"])
    except KeyError as err:
        raise RecordFieldError("the layout gives no relative_speed_sign for this class",
                               field="conventions.relative_speed_sign") from err
    return {
        "ego_speed_ms": raw["ego_vel_kmh"] / KMH,
        "npc_speed_ms": max(raw["ego_vel_kmh"] + sign * raw["cutter_vel_kmh"], 0.0) / KMH,
        "delta_speed_ms": raw["delta_vel_kmh"] / KMH,
        "npc_distance_m": raw["npc_distance_m"],
        "lane_change_direction": _move(raw["direction"].lower(), conventions),
        "npc_vehicle_type": raw["lead_vehicle_type"].lower(),
    }


def _move(direction: str, conventions: Conventions) -> str:
    """The way the cutter moves: a layout whose cut-in ``direction`` names the side the
    cutter comes from (``direction_is: from_side``) means the other way."""
    if conventions.get("direction_is") == "from_side":
        return {"left": "right", "right": "left"}.get(direction, direction)
    return direction


def sample(rng: np.random.Generator, n: int, code: str) -> Columns:
    behind = code.endswith("B")
    cut_out = code.startswith("COUT")
    ego = speeds_kmh(rng, n, 70, 130)
    if cut_out:  # thesis Table 4.3: REL and DELTA very small, the NPC nearly at ego speed
        rel = np.round(rng.uniform(0.1, 0.9, n) * rng.choice([-1, 1], n), 2)
        delta = np.round(rng.uniform(0.1, 0.9, n) * rng.choice([-1, 1], n), 2)
    else:
        rel = np.round(rng.normal(3 if behind else -3, 5, n), 1)
        delta = np.round(rng.normal(0, 3, n), 1)
    gap = np.round(rng.uniform(6, 45, n), 1)
    distance = -gap if behind else gap
    duration = np.round(rng.uniform(2.0, 6.0, n), 1)
    if code == "CINB":  # the merging car ends behind the ego: it gains at most gap - 9 m
        gap = np.maximum(gap, 12.0)
        distance = -gap
        gained_kmh = np.maximum(rel + delta / 2, 0.0)
        most_kmh = np.maximum((gap - 9.0) / duration * 3.6, 0.0)
        rel = np.where(gained_kmh > most_kmh, np.round(most_kmh - delta / 2 - 0.1, 1), rel)
    if n >= 1:  # edge row: the cutter at exactly the ego speed
        rel[0], delta[0] = 0.0, 0.0
    return {"ego_vel_kmh": ego, "cutter_vel_kmh": rel, "delta_vel_kmh": delta,
            "duration_s": duration, "npc_distance_m": distance,
            "other_dir_traffic": yes_no(rng, n), "direction": left_right(rng, n),
            "lead_vehicle_type": vehicle_types(rng, n)}


def cut_in_sides(params: Mapping[str, Any]) -> list[str]:
    """The cutter starts in the lane on the other side of the one it moves towards."""
    return ["right" if params.get("lane_change_direction") == "left" else "left"]


def cut_out_sides(params: Mapping[str, Any]) -> list[str]:
    """The NPC leaves towards ``lane_change_direction``: that lane must exist."""
    return [params["lane_change_direction"]]


def _cut_class(code: str, name: str, tag: str, cut_in: bool, behind: bool) -> Maneuver:
    return Maneuver(
        code=code, tag=tag, domain="highway", name=name, script=f"gen_hw_{code.lower()}.py",
        layout_fields=LAYOUT_FIELDS, extract=extract, sample=sample,
        relative_speed=True, ego_end_speed_factor=1.0 if cut_in or behind else 1.05,
        npc_position="behind" if behind else "front",
        lane_sides=cut_in_sides if cut_in else cut_out_sides, npc_starts_beside=cut_in,
        same_lane=None if cut_in else SameLane("npc", "npc_distance_m", "at_start"),
        npc_speed_change=True, lane_change="npc", npc_ends_in_ego_lane=cut_in,
        ego_reacts="from_cut_in" if cut_in and not behind else None)


MANEUVERS = (
    _cut_class("CINF", "NPC cuts in in front of the ego", "cut_in_front", True, False),
    _cut_class("CINB", "NPC cuts in behind the ego", "cut_in_behind", True, True),
    _cut_class("COUTF", "NPC in front cuts out of the ego's lane", "cut_out_front", False, False),
    _cut_class("COUTB", "NPC behind cuts out of the ego's lane", "cut_out_behind", False, True),
)

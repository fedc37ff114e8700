"""Params dicts built from docs/params.md, for matcher tests that do not go through ingest."""

from __future__ import annotations

from typing import Any

TAGS = {"BRAKE": "brake", "CINF": "cut_in_front", "CINB": "cut_in_behind", "LCF":
        "lane_change_front", "FLB": "follow_behind", "FRF": "free_ride_front",
        "U1_1": "in_lane_driving", "U4_1": "stop_at_tfl_red", "U4_3": "straight_tfl_green",
        "U4_4": "turn_right_at_tfl_green"}


def highway(code: str, *, ego_ms: float = 30.0, duration_s: float = 4.0,
            npc_distance_m: float | None = 25.0, sides: tuple[str, ...] = (),
            **extra: Any) -> dict[str, Any]:
    """A highway params dict; the gaps follow from ``npc_distance_m``."""
    params = {
        "scenario_id": f"{code}_B0_test_row000001", "maneuver_class": code,
        "maneuver_tag": TAGS[code], "domain": "highway", "weather_key": "Day_Clear",
        "duration_s": duration_s, "maneuver_start_s": 2.0,
        "timeout_s": 2.5 * (2.0 + duration_s), "ego_speed_ms": ego_ms,
        "ego_end_speed_ms": ego_ms, "has_npc": npc_distance_m is not None,
        "npc_position": None, "required_lane_sides": list(sides), "max_speed_ms": ego_ms,
        "gap_ahead_m": max(npc_distance_m or 0.0, 0.0),
        "gap_behind_m": max(-(npc_distance_m or 0.0), 0.0), "spawn_id": None,
    }
    if npc_distance_m is not None:
        params.update(npc_distance_m=npc_distance_m, npc_speed_ms=ego_ms - 2.0,
                      npc_position="front" if npc_distance_m >= 0 else "behind")
    params.update(extra)
    return params


def urban(code: str, *, tfl_ds_m: float | None = 40.0, speed_limit_kmh: float = 50.0,
          **extra: Any) -> dict[str, Any]:
    """An urban params dict."""
    params = {
        "scenario_id": f"{code}/1000.json", "maneuver_class": code, "maneuver_tag": TAGS[code],
        "domain": "urban", "weather_key": "Day_Clear", "duration_s": 8.0,
        "maneuver_start_s": 0.0, "timeout_s": 20.0, "ego_speed_ms": 9.0,
        "ego_end_speed_ms": 0.0, "has_npc": False, "npc_position": None,
        "required_lane_sides": [], "max_speed_ms": 9.0, "gap_ahead_m": 0.0, "gap_behind_m": 0.0,
        "tfl_ds_m": tfl_ds_m, "speed_limit_kmh": speed_limit_kmh, "drive_distance_m": 35.0,
        "spawn_id": None,
    }
    params.update(extra)
    return params

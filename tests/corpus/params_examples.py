"""One realistic params dict per manoeuvre class, written by hand from docs/params.md.

Spawn keys hold plausible CARLA Town04 values: highway road 45 (lanes -1..-4, s around 100),
urban world coordinates in the OpenSCENARIO frame. Used until real sample records flow through
``ingest.extract_params`` and ``spawn_db``, and as readable examples afterwards.
"""

from __future__ import annotations

import copy
from typing import Any

from corpus.retrieval import CLASS_TAGS as TAGS  # checked against docs/params.md

HIGHWAY_CLASSES = [code for code in TAGS if not code.startswith("U")]
URBAN_CLASSES = [code for code in TAGS if code.startswith("U")]


def _common(code: str, duration_s: float, start_s: float, ego: float, ego_end: float) -> dict:
    return {
        "scenario_id": f"{code}_example_row000007", "maneuver_class": code,
        "maneuver_tag": TAGS[code], "domain": "urban" if code.startswith("U") else "highway",
        "weather_key": "Day_Clear", "duration_s": duration_s, "maneuver_start_s": start_s,
        "timeout_s": round(2.5 * (start_s + duration_s), 3), "ego_speed_ms": ego,
        "ego_end_speed_ms": ego_end, "has_npc": False, "npc_position": None,
        "required_lane_sides": [], "spawn_id": 17,
    }


def _lane(actor: str, lane_id: int, s: float) -> dict:
    return {f"{actor}_road_id": 45, f"{actor}_lane_id": lane_id, f"{actor}_s": s,
            f"{actor}_x": 120.0 + s, f"{actor}_y": -30.5 + 3.5 * lane_id, f"{actor}_z": 0.3,
            f"{actor}_h": 0.02}


def _npc(speed: float, delta: float, distance: float, lane_id: int, vehicle: str = "car") -> dict:
    return {"has_npc": True, "npc_position": "front" if distance > 0 else "behind",
            "npc_speed_ms": speed, "delta_speed_ms": delta,
            "npc_end_speed_ms": max(speed + delta, 0.0), "npc_distance_m": distance,
            "npc_vehicle_type": vehicle, "other_dir_traffic": False,
            **_lane("npc", lane_id, 100.0 + distance)}


def _highway(code: str) -> dict:
    if code in ("BRAKE", "BR_BK"):
        params = _common(code, 3.4, 2.0, 27.5, 27.5)
        params |= _npc(25.0, -11.0, 32.0, -3, "truck") | {"brake_intensity": 0.62}
    elif code in ("CINF", "CINB", "COUTF", "COUTB"):
        ego = 26.0
        params = _common(code, 4.1, 2.0, ego, ego * 1.05 if code == "COUTF" else ego)
        distance = 18.0 if code.endswith("F") else -14.0
        cut_in = code.startswith("CIN")
        move = "left" if code in ("CINF", "COUTB") else "right"
        # a cut-in starts in the lane opposite to its move, a cut-out in the ego lane
        lane = (-4 if move == "left" else -2) if cut_in else -3
        params |= _npc(ego + (2.5 if code != "COUTB" else -2.5), -1.2, distance, lane, "van")
        params |= {"lane_change_direction": move,
                   "required_lane_sides": [("right" if move == "left" else "left") if cut_in
                                           else move]}
    elif code in ("LCF", "LCB"):
        move = "left" if code == "LCF" else "right"
        params = _common(code, 5.3, 2.0, 24.0, 26.5)
        params |= {"lane_change_direction": move, "other_dir_traffic": True,
                   "required_lane_sides": [move]}
    elif code in ("FLF", "FLB"):
        params = _common(code, 6.0, 2.0, 23.0, 21.0)
        distance = 40.0 if code == "FLF" else -35.0
        params |= _npc(22.0, -3.0, distance, -2, "car")
        params |= {"npc_distance_end_m": distance * 0.8, "npc_dist_traveled_m": 120.0,
                   "behavior_type": "B2"}
    else:
        params = _common(code, 8.0, 2.0, 30.0, 31.0)
        sign = 1.0 if code == "FRF" else -1.0
        slots = {"center": (True, -3, 45.0), "right": (True, -4, 20.0), "left": (False, -2, 0.0)}
        for slot, (present, lane, distance) in slots.items():
            params |= {f"{slot}_present": present,
                       f"{slot}_speed_ms": 29.0 if present else 0.0,
                       f"{slot}_end_speed_ms": 27.5 if present else 0.0,
                       f"{slot}_distance_m": sign * distance,
                       f"{slot}_end_distance_m": sign * distance * 0.9,
                       f"{slot}_vehicle_type": "truck" if slot == "right" else "car"}
            if present:
                params |= _lane(slot, lane, 100.0 + sign * distance)
        params |= {"ego_dist_traveled_m": 244.0, "required_lane_sides": ["right"]}
        params |= {"driving_side": "right"} if code == "FRF" else {"other_dir_traffic": False}
    return params | _lane("ego", -3, 100.0)


def _urban(code: str) -> dict:
    stops = code == "U4_1"
    params = _common(code, 9.5, 0.0, 11.2, 0.0 if stops else 12.4)
    params |= {
        "ego_x": 313.2, "ego_y": 171.8, "ego_z": 0.3, "ego_h": 1.5708,
        "init_speed_ms": 11.2, "final_speed_ms": params["ego_end_speed_ms"],
        "brake_time_s": 7.9 if stops else 9.5,
        "yellow_delay_s": None if code == "U1_1" else 2.6,
        "drive_distance_m": 44.0 if stops else 112.0,
        "tfl_ds_m": None if code == "U1_1" else 31.7,
        "tfl_state": {"U1_1": None, "U4_1": "red", "U4_2": "orange"}.get(code, "green"),
        "turn": "right" if code == "U4_4" else "straight",
        "speed_limit_kmh": 50, "lane_count": 2, "lane_width_m": 3.2, "road_type": "urban",
        "lead_present": code in ("U1_1", "U4_3"), "lead_distance_m": 0.0,
        "lead_speed_ms": 0.0, "lead_vehicle_type": None,
        "oncoming_present": False, "pedestrian_present": code == "U4_4", "min_ttc_s": None,
        "v_noise_std": 0.3, "dl_noise_std": 0.1, "t_noise_std": 0.05,
        "weather_key": "Night_Rain" if code == "U4_2" else "Day_Cloudy",
    }
    if params["lead_present"]:
        params |= {"lead_distance_m": 17.5, "lead_speed_ms": 10.4, "lead_vehicle_type": "car"}
    if code != "U1_1":
        params |= {"tfl_x_carla": 315.0, "tfl_y_carla": -140.2, "spawn_tfl_distance_m": 31.7,
                   "spawn_stop_line_distance_m": 24.4}
    return params


_EXAMPLES = {code: (_urban(code) if code.startswith("U") else _highway(code)) for code in TAGS}


def example_params(code: str) -> dict[str, Any]:
    """A fresh copy of the example params for ``code`` (tests may change it freely)."""
    return copy.deepcopy(_EXAMPLES[code])

"""One realistic params dict per manoeuvre class: written by hand from docs/params.md for the
17 classes of the thesis, and for a class added since (built in or a plugin) its first
sample record (``Maneuver.sample``), ingested and placed on Town04 by the spawn stage.

Spawn keys: highway on Town04's curved road 45 (lanes -1..-4), the ego at s = 100 and every
NPC where it stands at t = 0: its recorded gap minus the lead-in drift
``(v_npc - v_ego) x maneuver_start_s``, measured along its lane (docs/params.md), poses from
the map; urban world coordinates in the OpenSCENARIO frame, written by hand.
"""

from __future__ import annotations

import copy
import tempfile
from pathlib import Path
from typing import Any

from scenweave import maneuvers, roads
from scenweave.corpus.retrieval import class_tags
from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.ingest.samples import write_highway_samples, write_urban_samples
from scenweave.spawn_db import SpawnMatcher

TAGS = class_tags()  # checked against docs/params.md

EGO_S = 100.0
START_S = 2.0

HIGHWAY_CLASSES = maneuvers.codes("highway")
URBAN_CLASSES = maneuvers.codes("urban")
#: the classes whose example is written by hand below
HAND_WRITTEN = ("BRAKE", "BR_BK", "CINF", "CINB", "COUTF", "COUTB", "LCF", "LCB", "FLF", "FLB",
                "FRF", "FRB", "U1_1", "U4_1", "U4_2", "U4_3", "U4_4")


def _common(code: str, duration_s: float, start_s: float, ego: float, ego_end: float) -> dict:
    return {
        "scenario_id": f"{code}_example_row000007", "maneuver_class": code,
        "maneuver_tag": TAGS[code], "domain": "urban" if code.startswith("U") else "highway",
        "weather_key": "Day_Clear", "duration_s": duration_s, "maneuver_start_s": start_s,
        "timeout_s": round(2.5 * (start_s + duration_s), 3), "ego_speed_ms": ego,
        "ego_end_speed_ms": ego_end, "has_npc": False, "npc_position": None,
        "required_lane_sides": [], "spawn_id": 17,
    }


def _lane(actor: str, lane_id: int, ahead_m: float = 0.0) -> dict:
    """Spawn keys of ``actor`` in ``lane_id`` of road 45, ``ahead_m`` along it from s = 100."""
    road, lane, s = roads.advance_along_lane(45, lane_id, EGO_S, ahead_m)
    x, y, z, h = roads.lane_position_to_world(road, lane, s)
    return {f"{actor}_road_id": road, f"{actor}_lane_id": lane, f"{actor}_s": round(s, 4),
            f"{actor}_x": round(x, 4), f"{actor}_y": round(y, 4), f"{actor}_z": round(z, 4),
            f"{actor}_h": round(h, 6)}


def _start_ahead(distance: float, speed: float, ego: float) -> float:
    """How far ahead of the ego an actor stands at t = 0 for ``distance`` at the manoeuvre."""
    return distance - (speed - ego) * START_S


def _npc(speed: float, delta: float, distance: float, lane_id: int, ego: float,
         vehicle: str = "car") -> dict:
    return {"has_npc": True, "npc_position": "front" if distance > 0 else "behind",
            "npc_speed_ms": speed, "delta_speed_ms": delta,
            "npc_end_speed_ms": max(speed + delta, 0.0), "npc_distance_m": distance,
            "npc_vehicle_type": vehicle, "other_dir_traffic": False,
            **_lane("npc", lane_id, _start_ahead(distance, speed, ego))}


def _highway(code: str) -> dict:
    if code in ("BRAKE", "BR_BK"):
        params = _common(code, 3.4, START_S, 27.5, 27.5)
        params |= _npc(25.0, -11.0, 32.0, -3, 27.5, "truck") | {"brake_intensity": 0.62}
    elif code in ("CINF", "CINB", "COUTF", "COUTB"):
        ego = 26.0
        params = _common(code, 4.1, START_S, ego, ego * 1.05 if code == "COUTF" else ego)
        distance = 18.0 if code.endswith("F") else -14.0
        cut_in = code.startswith("CIN")
        move = "left" if code in ("CINF", "COUTB") else "right"
        # a cut-in starts in the lane opposite to its move, a cut-out in the ego lane
        lane = (-4 if move == "left" else -2) if cut_in else -3
        params |= _npc(ego + (2.5 if code != "COUTB" else -2.5), -1.2, distance, lane, ego,
                       "van")
        params |= {"lane_change_direction": move,
                   "required_lane_sides": [("right" if move == "left" else "left") if cut_in
                                           else move]}
    elif code in ("LCF", "LCB"):
        move = "left" if code == "LCF" else "right"
        params = _common(code, 5.3, START_S, 24.0, 26.5)
        params |= {"lane_change_direction": move, "other_dir_traffic": True,
                   "required_lane_sides": [move]}
    elif code in ("FLF", "FLB"):
        params = _common(code, 6.0, START_S, 23.0, 21.0)
        distance = 40.0 if code == "FLF" else -35.0
        params |= _npc(22.0, -3.0, distance, -2, 23.0, "car")
        params |= {"npc_distance_end_m": distance * 0.8, "npc_dist_traveled_m": 120.0,
                   "behavior_type": "B2"}
    else:  # FRF, FRB
        params = _common(code, 8.0, START_S, 30.0, 31.0)
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
                params |= _lane(slot, lane, _start_ahead(sign * distance, 29.0, 30.0))
        params |= {"ego_dist_traveled_m": 244.0, "required_lane_sides": ["right"]}
        params |= {"driving_side": "right"} if code == "FRF" else {"other_dir_traffic": False}
    return params | _lane("ego", -3)


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
    if params["lead_present"]:  # 17.5 m along the ego's (straight, northbound) lane
        params |= {"lead_distance_m": 17.5, "lead_speed_ms": 10.4, "lead_vehicle_type": "car",
                   "lead_x": 313.2, "lead_y": 189.3, "lead_z": 0.3, "lead_h": 1.5708}
    if code != "U1_1":
        params |= {"tfl_x_carla": 315.0, "tfl_y_carla": -140.2, "spawn_tfl_distance_m": 31.7,
                   "spawn_stop_line_distance_m": 24.4}
    exit_keys = {"x": 326.4, "y": 208.9, "z": 0.3, "h": 0.0, "road_id": 8, "lane_id": -1,
                 "s": 10.0}  # east, 10 m into the road the right movement leads to
    params |= {f"turn_exit_{key}": value if code == "U4_4" else None
               for key, value in exit_keys.items()}
    return params


def _sampled(code: str) -> dict:
    """The first sample record of ``code`` (seed 7), ingested and placed on Town04."""
    with tempfile.TemporaryDirectory(prefix="scenweave-example-") as folder:
        raw = Path(folder)
        write_highway_samples(raw / "highway", seed=7, per_class=1)
        write_urban_samples(raw / "urban", seed=7, per_class=1)
        records = [extract_params(item.record) for item in iter_raw_records(raw, IngestReport())]
    record = next(params for params in records if params["maneuver_class"] == code)
    return SpawnMatcher().assign(record, 0)


def _example(code: str) -> dict:
    if code not in HAND_WRITTEN:
        return _sampled(code)
    return _urban(code) if maneuvers.get(code).domain == "urban" else _highway(code)


_EXAMPLES = {code: _example(code) for code in TAGS}


def example_params(code: str) -> dict[str, Any]:
    """A fresh copy of the example params for ``code`` (tests may change it freely)."""
    return copy.deepcopy(_EXAMPLES[code])

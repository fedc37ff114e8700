"""Small builders for hand-made MOOVE inputs used across the ingest tests."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def write_npy(folder: Path, code: str, rows: list[list[str]]) -> Path:
    """Write ``rows`` as a MOOVE object array file ``<code>_BINS_VALUES.npy``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{code}_BINS_VALUES.npy"
    array = np.empty((len(rows), len(rows[0]) if rows else 0), dtype=object)
    for i, row in enumerate(rows):
        array[i, :] = row
    np.save(path, array, allow_pickle=True)
    return path


def scene(code: str, speeds_kmh: list[float], times: list[float], odometer: list[float],
          light: tuple[float, int] | None = None, obstacles: list[list[dict]] | None = None,
          precipitation: int = 0, day_period: int = 1) -> dict:
    """A minimal but complete ADScene object with the given ego kinematics."""
    frames = []
    for i, (t, v, odo) in enumerate(zip(times, speeds_kmh, odometer, strict=True)):
        frames.append({
            "time": t,
            "ego_vehicle": {
                "ego_speed": v, "longitudinal_acceleration_wheels": 0.0,
                "steer_wheel_angle": 0.0, "ego_brake": 0, "ego_lane": 1,
                "turning_signal_state": 0, "yaw_rate": 0.0, "covered_distance_by_ego": odo,
                "dist_to_marking_left": -1.7, "dist_to_marking_right": 1.7,
            },
            "temporal_climatic": {"day_period": day_period, "outside_temperature": 15.0,
                                  "dazzled": 0, "fog": 0, "precipitation": precipitation},
            "positioning": {"latitude": 48.0, "longitude": 2.0},
            "obstacles": obstacles[i] if obstacles else [],
        })
    points = [{"position_longi_from_0": 0.0, "infrastructure_elements": [
        {"type": "SpeedLimit", "value": 50}, {"type": "RoadType", "value": 3},
        {"type": "NumberOfLanes", "value": 2}, {"type": "LaneWidth", "value": 3.5}]}]
    if light:
        points.append({"position_longi_from_0": light[0],
                       "infrastructure_elements": [{"type": "TrafficSignType",
                                                    "value": light[1]}]})
    return {
        "scenario_code": code,
        "segment": {"type": code, "begin_time": times[0], "end_time": times[-1],
                    "record": {"name": "T", "date_time": "2023-05-12T14:32:10",
                               "provider": "test", "campaign": "MOOVE",
                               "input_data_version": "1"}},
        "environment": {"infrastructure": {"way_points": points}},
        "attributes": [{"type": "code_country", "value": "250"}],
        "key_times": frames,
    }


def obstacle(uid: int, pos_x: float, vx: float, ego_v_ms: float, rel_lane: int = 0,
             classification: int = 1, ttc: float = -1.0, pos_y: float = 0.0) -> dict:
    """One obstacle entry with the fields the canonicaliser reads."""
    return {"unique_id": uid, "pos_x": pos_x, "pos_y": pos_y,
            "relative_velocity_x": vx - ego_v_ms, "relative_velocity_y": 0.0,
            "absolute_velocity_x": vx, "mobile_object_classification": classification,
            "obstacle_relative_lane": rel_lane, "blinker": 0, "time_to_collision": ttc}


def write_scene(folder: Path, data: dict, name: str | None = None) -> Path:
    """Write an ADScene object as ``<folder>/<code>/<begin>.json``."""
    sub = folder / data["scenario_code"]
    sub.mkdir(parents=True, exist_ok=True)
    path = sub / (name or f"{data['segment']['begin_time']:.1f}.json")
    path.write_text(json.dumps(data), encoding="utf-8")
    return path

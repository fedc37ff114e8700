"""Urban sample files: ADScene JSON, one per instance, ``<CODE>/<begin_time>.json``.

Each file is a small simulation of the manoeuvre (thesis §4.2, Appendix A): the ego's speed
profile (cruise, brake to a stop before a red light, pass on green, slow and turn right),
irregular key_times, road geometry and the traffic light as infrastructure way points, and
some lead vehicles, oncoming traffic, pedestrians, rain and night.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenweave import maneuvers
from scenweave.maneuvers.sampling import sample_stream

GREEN, ORANGE, RED = 167, 170, 172
METRES_PER_DEG_LAT = 111_320.0


@dataclass
class EgoProfile:
    """Ego speed (m/s) and distance travelled (m) at each key time (s from segment start)."""

    t: np.ndarray
    v: np.ndarray
    s: np.ndarray
    light_at_m: float | None
    light_code: int | None
    turn_from_m: float | None = None


def write_urban_samples(out_dir: Path, seed: int, per_class: int) -> list[Path]:
    """Write ``per_class`` ADScene files for each urban class under ``out_dir/<CODE>/``."""
    paths = []
    for maneuver in maneuvers.seeding_order("urban"):
        code = maneuver.code
        rng = sample_stream(seed, code)
        folder = out_dir / code
        folder.mkdir(parents=True, exist_ok=True)
        used: set[float] = set()
        for _ in range(per_class):
            scene = make_scene(code, rng, taken=used)
            used.add(scene["segment"]["begin_time"])
            path = folder / f"{scene['segment']['begin_time']:.1f}.json"
            path.write_text(json.dumps(scene, indent=1), encoding="utf-8")
            paths.append(path)
    return paths


def make_scene(code: str, rng: np.random.Generator, taken: set[float] | None = None) -> dict:
    """One ADScene instance of class ``code``; its begin_time (the file name) is not one of
    ``taken``: a drawn time already used moves on by 0.1 s until it is free."""
    maneuver = maneuvers.get(code)
    profile = _ego_profile(maneuver, rng)
    night = rng.random() < 0.2
    rain = rng.random() < 0.2
    begin = round(float(rng.uniform(60, 7200)), 1)
    while begin in (taken or ()):
        begin = round(begin + 0.1, 1)
    t_abs = begin + profile.t
    actors = _actors(maneuver, rng, profile)
    frames = [_frame(i, profile, actors, rng, night, rain) for i in range(len(profile.t))]
    for frame, t in zip(frames, t_abs, strict=True):
        frame["time"] = round(float(t), 3)
    return {
        "scenario_code": code,
        "segment": {
            "type": code, "begin_time": begin, "end_time": round(float(t_abs[-1]), 3),
            "record": {
                "name": f"MOOVE_FR_{int(rng.integers(1, 9999)):04d}",
                "date_time": _date_time(rng), "provider": "ELIOS Lab",
                "campaign": "MOOVE", "input_data_version": "2.3",
            },
            "processing_version": "1.7",
        },
        "environment": {"infrastructure": {"way_points": _way_points(code, rng, profile)}},
        "attributes": [{"type": "code_country", "value": "250"}],
        "key_times": frames,
    }


def _date_time(rng: np.random.Generator) -> str:
    day = int(rng.integers(1, 28))
    month = int(rng.integers(1, 12))
    hour, minute = int(rng.integers(6, 22)), int(rng.integers(0, 59))
    return f"2023-{month:02d}-{day:02d}T{hour:02d}:{minute:02d}:00"


def _times(rng: np.random.Generator, duration: float) -> np.ndarray:
    if rng.random() < 0.3:
        steps = np.full(int(duration / 0.2) + 1, 0.2)
    else:
        steps = rng.uniform(0.1, 0.6, int(duration / 0.1) + 2)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    return np.round(t[t <= duration + 1e-9], 3)


def _ego_profile(maneuver: maneuvers.Maneuver, rng: np.random.Generator) -> EgoProfile:
    if maneuver.light is None:
        v0 = rng.uniform(30, 70) / 3.6
        t = _times(rng, float(rng.uniform(8, 15)))
        v = v0 + 0.3 * np.sin(t * rng.uniform(0.2, 0.6))
        return EgoProfile(t, v, _integrate(t, v), None, None)
    light_at = float(rng.uniform(45, 90))
    if maneuver.stops_at_line:
        return _stop_profile(rng, light_at)
    if maneuver.turn == "right":
        return _turn_profile(rng, light_at)
    v0 = rng.uniform(35, 65) / 3.6
    t = _times(rng, (light_at + 25) / v0)
    v = np.full_like(t, v0) + rng.normal(0, 0.05, len(t))
    code_seen = GREEN if maneuver.light == "green" or rng.random() < 0.6 else ORANGE
    return EgoProfile(t, v, _integrate(t, v), light_at, code_seen)


def _stop_profile(rng: np.random.Generator, light_at: float) -> EgoProfile:
    v0 = rng.uniform(30, 60) / 3.6
    stop_at = light_at - rng.uniform(4, 12)
    decel = rng.uniform(1.5, 3.5)
    cruise = stop_at - v0**2 / (2 * decel)
    if cruise < 5:
        cruise = 5.0
        decel = v0**2 / (2 * (stop_at - cruise))
    t_brake = cruise / v0
    t_stop = t_brake + v0 / decel
    t = _times(rng, t_stop + float(rng.uniform(2, 5)))
    v = np.clip(np.where(t < t_brake, v0, v0 - decel * (t - t_brake)), 0, None)
    light = RED if rng.random() < 0.7 else ORANGE
    return EgoProfile(t, v, _integrate(t, v), light_at, light)


def _turn_profile(rng: np.random.Generator, light_at: float) -> EgoProfile:
    v0 = rng.uniform(30, 50) / 3.6
    v_turn = rng.uniform(15, 25) / 3.6
    slow_from = max(light_at - 30, 5.0)
    decel = (v0**2 - v_turn**2) / (2 * (light_at - slow_from))
    duration = slow_from / v0 + (v0 - v_turn) / decel + 20 / v_turn
    t = _times(rng, duration)
    t_slow = slow_from / v0
    v = np.clip(np.where(t < t_slow, v0, v0 - decel * (t - t_slow)), v_turn, None)
    return EgoProfile(t, v, _integrate(t, v), light_at, GREEN, turn_from_m=light_at)


def _integrate(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.diff(t) * (v[1:] + v[:-1]) / 2)])


def _actors(maneuver: maneuvers.Maneuver, rng: np.random.Generator,
            profile: EgoProfile) -> list[dict]:
    actors = []
    if maneuver.lead_allowed and rng.random() < 0.5:
        actors.append({"kind": "lead", "id": int(rng.integers(100, 999)),
                       "gap": float(rng.uniform(12, 40)),
                       "v": float(profile.v[0] + rng.normal(-0.5, 1.0)), "class": 1})
    if rng.random() < 0.4:
        actors.append({"kind": "oncoming", "id": int(rng.integers(1000, 1999)),
                       "gap": float(rng.uniform(60, 120)), "v": float(rng.uniform(8, 14)),
                       "class": 3 if rng.random() < 0.15 else 1})
    if maneuver.light is not None and rng.random() < 0.3 and profile.light_at_m is not None:
        actors.append({"kind": "pedestrian", "id": int(rng.integers(2000, 2999)),
                       "gap": profile.light_at_m + 3, "v": 1.3, "class": 4,
                       "side": float(rng.choice([-1.0, 1.0]))})
    return actors


def _frame(i: int, p: EgoProfile, actors: list[dict], rng: np.random.Generator, night: bool,
           rain: bool) -> dict:
    t, v, s = float(p.t[i]), float(p.v[i]), float(p.s[i])
    accel = float(np.gradient(p.v, p.t)[i]) if len(p.t) > 1 else 0.0
    turning = p.turn_from_m is not None and s >= p.turn_from_m
    signal = 1 if p.turn_from_m is not None and s >= p.turn_from_m - 40 else 0
    steer = float(rng.uniform(90, 200)) if turning else float(rng.normal(0, 2))
    lat, lon = 48.7744 + s * 0.7 / METRES_PER_DEG_LAT, 2.1836 + s * 0.7 / 73_400.0
    front = next((a["id"] for a in actors if a["kind"] == "lead"), -1)
    ego = {
        "steer_wheel_angle": round(steer, 2), "steer_wheel_angle_speed": round(rng.normal(0, 3), 2),
        "yaw_rate": round(v * 0.12 if turning else float(rng.normal(0, 0.3)), 3),
        "ego_brake": 1 if accel < -0.5 else 0, "driver_will": 0,
        "lateral_acceleration": round(v * v * 0.01 if turning else float(rng.normal(0, 0.05)), 3),
        "engine_speed": round(800 + v * 45, 1), "ego_speed": round(v * 3.6, 2),
        "covered_distance_by_ego": round(15234.0 + s, 2),
        "longitudinal_acceleration_wheels": round(accel, 3),
        "dist_to_road_boundaries_left": round(5.2 + float(rng.normal(0, 0.05)), 2),
        "dist_to_road_boundaries_right": round(1.9 + float(rng.normal(0, 0.05)), 2),
        "front_id": front,
        "dist_to_marking_left": round(-1.66 + float(rng.normal(0, 0.03)), 2),
        "dist_to_marking_right": round(1.55 + float(rng.normal(0, 0.03)), 2),
        "marking_type_left": 3, "marking_type_right": 2, "latitude": round(lat, 6),
        "longitude": round(lon, 6), "turning_signal_state": signal, "ego_lane": 1,
    }
    return {
        "ego_vehicle": ego,
        "temporal_climatic": {"day_period": 2 if night else 1,
                              "outside_temperature": round(float(rng.normal(14, 0.2)), 1),
                              "dazzled": 0, "fog": 0, "precipitation": 2 if rain else 0},
        "positioning": {"latitude": ego["latitude"], "longitude": ego["longitude"]},
        "obstacles": [o for a in actors if (o := _obstacle(a, t, v, s, rng)) is not None],
    }


def _obstacle(actor: dict, t: float, ego_v: float, ego_s: float,
              rng: np.random.Generator) -> dict | None:
    kind = actor["kind"]
    if kind == "lead":
        pos_x, pos_y, vx, vy = actor["gap"] + actor["v"] * t - ego_s, 0.1, actor["v"], 0.0
        rel_lane = 0
    elif kind == "oncoming":
        pos_x, pos_y, vx, vy = actor["gap"] - actor["v"] * t - ego_s, 3.4, -actor["v"], 0.0
        rel_lane = 1
    else:
        pos_x = actor["gap"] - ego_s
        pos_y = actor["side"] * (5.0 - actor["v"] * t)
        vx, vy, rel_lane = 0.0, -actor["side"] * actor["v"], 2 * int(actor["side"])
        if abs(pos_y) > 6:
            return None
    if pos_x < -15 or pos_x > 150:
        return None
    closing = ego_v - vx
    ttc = pos_x / closing if closing > 0.1 and pos_x > 0 and rel_lane == 0 else -1.0
    return {
        "role": 0, "confidence": round(float(rng.uniform(0.8, 1.0)), 2),
        "unique_id": actor["id"], "pos_x": round(pos_x, 2), "pos_y": round(pos_y, 2),
        "obstacle_length": 0.5 if actor["class"] == 4 else 4.5,
        "obstacle_width": 0.5 if actor["class"] == 4 else 1.8,
        "relative_velocity_x": round(vx - ego_v, 3), "relative_velocity_y": round(vy, 3),
        "absolute_velocity_x": round(vx, 3), "absolute_velocity_y": round(vy, 3),
        "relative_acceleration_x": 0.0, "absolute_acceleration_x": 0.0,
        "time_between_vehicles": round(pos_x / ego_v, 2) if ego_v > 0.1 and pos_x > 0 else -1.0,
        "orientation": round(math.pi if kind == "oncoming" else 0.0, 3), "status_mobile": 1,
        "fixed_object_classification": 0, "mobile_object_classification": actor["class"],
        "age": round(t + 1.0, 1), "age_max": 60.0, "obstacle_lane": 1 + rel_lane,
        "obstacle_relative_lane": rel_lane, "blinker": 0, "in_front_Brake": 0, "lane_shift": 0,
        "time_to_collision": round(ttc, 2),
    }


def _way_points(code: str, rng: np.random.Generator, p: EgoProfile) -> list[dict]:
    road_type = 3 if rng.random() < 0.5 else 2
    width = round(float(rng.uniform(3.0, 3.6)), 2)
    points = []
    for at in np.arange(0.0, float(p.s[-1]) + 1, 25.0):
        curvature = round(float(rng.normal(0, 0.0008)), 5)
        elements = [{"type": "LaneWidth", "value": width},
                    {"type": "FrontCurvature", "value": curvature},
                    {"type": "RearCurvature", "value": curvature},
                    {"type": "Slope", "value": round(float(rng.normal(0, 0.01)), 4)}]
        if at == 0.0:
            elements = [{"type": "SpeedLimit", "value": 50 if road_type == 3 else 70},
                        {"type": "RoadType", "value": road_type},
                        {"type": "NumberOfLanes", "value": 2},
                        {"type": "GuardRail", "value": 0}, *elements]
        points.append({"position_longi_from_0": round(float(at), 2),
                       "infrastructure_elements": elements})
    if p.light_at_m is not None:
        points.append({"position_longi_from_0": round(p.light_at_m, 2),
                       "infrastructure_elements": [{"type": "TrafficSignType",
                                                    "value": p.light_code}]})
    if rng.random() < 0.3:
        points.append({"position_longi_from_0": round(float(rng.uniform(5, 30)), 2),
                       "infrastructure_elements": [{"type": "TrafficSignType", "value": 257}]})
    return sorted(points, key=lambda w: w["position_longi_from_0"])

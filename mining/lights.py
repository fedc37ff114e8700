"""Urban events at traffic lights: a car stopping at red (U4_1) or passing on green (U4_3).

A light's stop line is where it stands along the road of the lanes it controls
(``TrafficLight.stop_line_s``, the tracks' ``s`` frame). Each event becomes an ADScene object,
the format of MOOVE's urban files, which ingest's own canonicaliser turns into the record:
the car's speed and odometer per step, the light at the stop line with the colour the car saw,
and the car ahead of it as an obstacle.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterator

import numpy as np

from scenweave.ingest.codes import TRAFFIC_LIGHT_STATES
from scenweave.mining.scene import KMH, Event, Scene
from scenweave.mining.tracks import Floats, Mask, TrafficLight

CODE_OF_STATE = {state: code for code, state in TRAFFIC_LIGHT_STATES.items()} | {
    "yellow": next(c for c, state in TRAFFIC_LIGHT_STATES.items() if state == "orange")}
#: what a recording without weather or road data is taken as (documented in docs/mining.md)
ASSUMED_ROAD = {"SpeedLimit": 50, "RoadType": 3, "NumberOfLanes": 2, "LaneWidth": 3.5}
HISTORY_S = 15.0
AFTER_STOP_S = 3.0
AFTER_PASS_M = 20.0
STRAIGHT_WITHIN_RAD = np.radians(20.0)


def state_at(light: TrafficLight, t: float) -> str | None:
    return next((p.state for p in light.phases if p.start_s <= t < p.end_s), None)


def light_events(scene: Scene) -> Iterator[Event]:
    for light in scene.recording.lights:
        line_s = light.stop_line_s
        if line_s is None or light.stop_lines:  # lines as segments: mining.urban
            continue
        for i, track in enumerate(scene.tracks):
            on = np.isin(track.lane.astype(str), list(light.lanes))
            if on.any():
                yield from _stop_or_pass(scene, i, light, line_s, on)


def _stop_or_pass(scene: Scene, i: int, light: TrafficLight, line_s: float,
                  on: Mask) -> Iterator[Event]:
    """``light``'s events of track ``i`` (``line_s``: the light's ``stop_line_s``)."""
    limits = scene.thresholds["light"]
    track, speed = scene.tracks[i], scene.motion[i].speed
    front = track.s + track.length_m / 2
    to_line = line_s - front
    stopped = (speed < limits["stopped_below_ms"]) & on & (to_line >= 0) \
        & (to_line <= limits["stop_before_line_m"])
    for k in np.flatnonzero(stopped)[:1].tolist():
        t = float(track.t[k])
        first = int(np.searchsorted(track.t, t - HISTORY_S))
        if state_at(light, t) in ("red", "yellow") and speed[first] > 2 * limits[
                "stopped_below_ms"] and _first_in_line(scene, i, k, line_s):
            last = int(np.searchsorted(track.t, t + AFTER_STOP_S, side="right")) - 1
            yield _event(scene, "U4_1", i, line_s, first, last, "red")
    crossed = np.flatnonzero(on[:-1] & (to_line[:-1] > 0) & (to_line[1:] <= 0))
    for k in crossed[:1].tolist():
        t = float(track.t[k + 1])
        start_k = np.flatnonzero(to_line >= limits["approach_from_m"])
        end_k = np.flatnonzero(to_line <= -AFTER_PASS_M)
        if state_at(light, t) != "green" or not len(start_k) or not len(end_k):
            continue
        first, last = int(start_k[-1]), int(end_k[0])
        if first < k and abs(_turned(track.heading[k + 1:last + 1])) <= STRAIGHT_WITHIN_RAD:
            yield _event(scene, "U4_3", i, line_s, first, last, "green")


def _first_in_line(scene: Scene, i: int, k: int, line_s: float) -> bool:
    leader = scene.traffic.leader(i, k)
    if leader is None:
        return True
    ahead = scene.tracks[leader.track]
    return float(ahead.s[leader.step] - ahead.length_m / 2) > line_s


def _turned(headings: Floats) -> float:
    if len(headings) < 2:
        return 0.0
    return float(np.unwrap(headings)[-1] - np.unwrap(headings)[0])


def _event(scene: Scene, code: str, i: int, line_s: float, first: int, last: int,
           colour: str) -> Event:
    track = scene.tracks[i]
    start, end = float(track.t[first]), float(track.t[last])
    adscene = adscene_of(scene, code, i, first, last, line_s, colour)
    series = scene.series({"ego": i}, i, start, end)
    return Event(code, track.id, None, round(start, 3), round(end, 3), {}, series,
                 adscene=adscene)


def adscene_of(scene: Scene, code: str, i: int, first: int, last: int, line_s: float,
               colour: str) -> dict:
    """The event as an ADScene object (MOOVE's urban file format); ``line_s``: the light's
    stop line along the road (``TrafficLight.stop_line_s``)."""
    track, speed = scene.tracks[i], scene.motion[i].speed
    odometer = track.s[first:last + 1] - track.s[first]
    frames = [frame_of(scene, i, k, float(speed[k]), float(odo))
              for k, odo in zip(range(first, last + 1), odometer, strict=True)]
    light_at = float(line_s - track.s[first])
    signs = [{"position_longi_from_0": round(light_at, 2), "infrastructure_elements": [
        {"type": "TrafficSignType", "value": CODE_OF_STATE[colour]}]}]
    return adscene_header(scene, code, float(track.t[first]), float(track.t[last]), signs,
                          frames)


def adscene_header(scene: Scene, code: str, start: float, end: float, signs: list[dict],
                   frames: list[dict]) -> dict:
    """An ADScene object: the segment, the assumed road with ``signs`` along it, ``frames``."""
    return {
        "scenario_code": code,
        "segment": {"type": code, "begin_time": round(start, 3), "end_time": round(end, 3),
                    "record": {"name": scene.recording.source, "date_time": "",
                               "provider": scene.recording.reader, "campaign": "mined",
                               "input_data_version": "1"}},
        "environment": {"infrastructure": {"way_points": [
            {"position_longi_from_0": 0.0, "infrastructure_elements": [
                {"type": kind, "value": value} for kind, value in ASSUMED_ROAD.items()]},
            *signs]}},
        "key_times": frames,
    }


def frame_of(scene: Scene, i: int, k: int, speed: float, odometer: float) -> dict:
    track = scene.tracks[i]
    lead = scene.traffic.leader(i, k)
    obstacles = [] if lead is None else [_obstacle(scene, i, k, lead.track, speed)]
    return {
        "time": round(float(track.t[k]), 3),
        "ego_vehicle": {"ego_speed": round(speed * KMH, 3),
                        "longitudinal_acceleration_wheels": 0.0, "steer_wheel_angle": 0.0,
                        "ego_brake": 0, "ego_lane": 1, "turning_signal_state": 0,
                        "yaw_rate": 0.0, "covered_distance_by_ego": round(odometer, 3),
                        "dist_to_marking_left": -1.7, "dist_to_marking_right": 1.7},
        "temporal_climatic": {"day_period": 1, "outside_temperature": None, "dazzled": 0,
                              "fog": 0, "precipitation": 0},
        "obstacles": obstacles,
    }


def _obstacle(scene: Scene, i: int, k: int, lead: int, ego_speed: float) -> dict:
    t = float(scene.tracks[i].t[k])
    gap = scene.gap(i, lead, t) or 0.0
    lead_speed = scene.speed(lead, t) or 0.0
    ahead = scene.tracks[lead]
    return {"unique_id": zlib.crc32(ahead.id.encode()) % 10**6, "pos_x": round(gap, 2),
            "pos_y": 0.0, "relative_velocity_x": round(lead_speed - ego_speed, 3),
            "absolute_velocity_x": round(lead_speed, 3),
            "mobile_object_classification": 3 if ahead.vehicle_type == "truck" else 1,
            "obstacle_relative_lane": 0}

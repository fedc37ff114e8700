"""Urban ADScene JSON files -> canonical records (thesis §4.4, Table 4.10).

Beyond reshaping, this decodes the RT_* code tables, gives each obstacle a role, rebuilds
ego and actor trajectories relative to their start, measures time-step regularity and the
minimum time-to-collision, and writes a two-sentence description.
"""

from __future__ import annotations

import dataclasses
import json
import re
import statistics
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from scenweave import maneuvers
from scenweave.ingest.codes import TRAFFIC_LIGHT_STATES, code_tables, decode
from scenweave.ingest.issues import Issue, RecordIssue, unexpected_issue

RECORD_VERSION = "urban.v1"
REGULAR_STEP_TOLERANCE = 0.1  # steps within 10 % of the median count as regular
DEFAULT_PERTURBATION = {"dl_noise_std": 0.2, "v_noise_std": 0.5, "t_noise_std": 0.2}
EGO_FIELDS = ("ego_speed", "longitudinal_acceleration_wheels", "steer_wheel_angle", "ego_brake",
              "ego_lane", "turning_signal_state", "yaw_rate", "covered_distance_by_ego",
              "dist_to_marking_left", "dist_to_marking_right")
OBSTACLE_FIELDS = ("unique_id", "pos_x", "pos_y", "relative_velocity_x", "absolute_velocity_x",
                   "mobile_object_classification", "obstacle_relative_lane")
OPTIONAL_OBSTACLE_FIELDS = ("relative_velocity_y", "blinker", "time_to_collision")
#: climate fields given as codes of these tables (or, tolerated, their labels)
CLIMATE_CODE_TABLES = {"day_period": "RT_DayPeriod", "precipitation": "RT_Precipitation"}
CLIMATE_FLAGS = ("dazzled", "fog")
#: way-point element types the record uses, with the lowest value that makes sense (numbers)
NUMERIC_ELEMENTS: dict[str, float | None] = {
    "SpeedLimit": 0, "LaneWidth": 0, "NumberOfLanes": 0, "FrontCurvature": None,
    "RearCurvature": None, "Slope": None, "RoadType": 0, "GuardRail": 0, "Junction": 0,
    "PresenceOfEmergencyLane": 0, "TrafficSignType": 0,
}
#: way-point elements whose codes may also be given by their label (``"Urban Road"``)
ELEMENT_CODE_TABLES = {"RoadType": "RT_RoadType", "GuardRail": "RT_GuardRail",
                       "Junction": "RT_JunctionBifurcation",
                       "TrafficSignType": "RT_TrafficSignType",
                       "PresenceOfEmergencyLane": "RT_PresenceOfEmergencyLane"}
#: what the file being read holds in a form we did not expect but can read (set per file)
_NOTES: ContextVar[list[RecordIssue] | None] = ContextVar("urban_notes", default=None)


def iter_urban_files(folder: Path) -> Iterator[Path]:
    """ADScene files ``<CODE>/<begin_time>.json`` in ``folder`` or ``folder/urban``, sorted."""
    for base in (folder, folder / "urban"):
        if base.is_dir():
            for sub in sorted(p for p in base.iterdir() if p.is_dir()):
                if re.fullmatch(r"U\d+_\d+", sub.name) or sub.name in maneuvers.codes("urban"):
                    yield from sorted(sub.glob("*.json"))


def canonicalize_urban_file(path: Path) -> tuple[dict | None, list[Issue]]:
    """Read one ADScene file; return its canonical record (or None) and its issues."""
    name = f"{path.parent.name}/{path.name}"
    notes: list[RecordIssue] = []
    try:
        scene = _read_json(path)
        record = canonicalize_scene(scene, name, folder_code=path.parent.name, notes=notes)
        return record, [_warning(note, name) for note in notes]
    except RecordIssue as issue:
        return None, [issue.to_issue(name)]
    except Exception as err:  # noqa: BLE001 - last line of defence: one file, not the batch
        return None, [unexpected_issue(name, err)]


def _read_json(path: Path) -> dict:
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as err:
        raise RecordIssue(f"not UTF-8 text (byte {err.start}: {err.reason})") from err
    except OSError as err:
        raise RecordIssue(f"cannot read: {err.strerror}") from err
    try:
        scene = json.loads(text)
    except json.JSONDecodeError as err:
        raise RecordIssue(f"invalid or truncated JSON at line {err.lineno}, column {err.colno}: "
                          f"{err.msg}") from err
    if not isinstance(scene, dict):
        raise RecordIssue("the top level must be a JSON object")
    return scene


def _warning(note: RecordIssue, file: str) -> Issue:
    return dataclasses.replace(note.to_issue(file), severity="warning")


def canonicalize_scene(scene: dict, source: str, folder_code: str | None = None,
                       notes: list[RecordIssue] | None = None) -> dict:
    """Turn one parsed ADScene object into a canonical urban record (RecordIssue if bad).

    A field in a form we did not expect but can read (a day period written as ``"Night"``
    instead of its code) is read and noted in ``notes``, not rejected."""
    token = _NOTES.set(notes if notes is not None else [])
    try:
        return _canonical(scene, source, folder_code)
    finally:
        _NOTES.reset(token)


def _canonical(scene: dict, source: str, folder_code: str | None) -> dict:
    notes = _NOTES.get()
    assert notes is not None
    code = _get(scene, "scenario_code", str)
    maneuver = maneuvers.find(code)
    if maneuver is None or maneuver.domain != "urban":
        raise RecordIssue(f"unknown urban class {code!r} "
                          f"(known: {', '.join(maneuvers.codes('urban'))})", field="scenario_code")
    if folder_code in maneuvers.codes("urban") and folder_code != code:
        raise RecordIssue(f"file is in folder {folder_code} but says {code}",
                          field="scenario_code")
    segment = _get(scene, "segment", dict)
    frames = _frames(scene, notes)
    times = [f["time"] for f in frames]
    ego = _ego_trajectory(frames)
    infra = _infrastructure(scene, notes)
    environment = _environment(frames[0], infra, scene)
    actors_start, actor_tracks = _actors(frames, ego["ds"])
    min_ttc = _min_ttc(frames)
    record = {
        "version": RECORD_VERSION,
        "scenario_id": _scenario_id(code, segment, source),
        "maneuver_class": code,
        "maneuver_tag": maneuver.tag,
        "domain": _slug(environment["road_type"]),
        "semantics": {
            "main_maneuver": maneuver.tag,
            "description": "",
            "tags": _tags(code, environment, actors_start),
            "criticality_metric": {"min_ttc_s": min_ttc, "source": "obstacles.time_to_collision"},
        },
        "metadata": _metadata(segment, source, times, scene),
        "environment": environment,
        "infrastructure": infra,
        "initial_state": {"ego": _ego_state(frames[0]), "actors": actors_start},
        "dynamic_content": {
            "ego_trajectory": ego,
            "actor_trajectories": actor_tracks,
            "summary": _summary(ego),
            "events": [],
        },
        "final_state": {"ego": _ego_state(frames[-1]),
                        "actors": [_actor_state(o) for o in frames[-1]["obstacles"]]},
        "perturbation": dict(DEFAULT_PERTURBATION),
    }
    record["semantics"]["description"] = describe(record)
    return record


# -- reading, with errors that name the field --------------------------------------------------

def _get(obj: dict, key: str, kind: type | tuple[type, ...], where: str = "") -> Any:
    path = f"{where}.{key}" if where else key
    if key not in obj:
        raise RecordIssue("missing", field=path)
    value = obj[key]
    if kind is float:
        kind = (int, float)
        if isinstance(value, str):
            value = obj[key] = _number_in_text(value, path)
    if isinstance(value, bool) and kind is not bool or not isinstance(value, kind):
        raise RecordIssue(f"expected {_kind_name(kind)}, got {type(value).__name__} {value!r:.40}",
                          field=path)
    if isinstance(value, float) and value != value or value in (float("inf"), float("-inf")):
        raise RecordIssue(f"not a finite number: {value!r}", field=path)
    return value


def _number_in_text(text: str, path: str) -> float | str:
    """A number written as text (``"3.5"``) as the number, with a note; other text as is (the
    caller's type check then names it)."""
    try:
        number = float(text)
    except ValueError:
        return text
    notes = _NOTES.get()
    if notes is not None:
        notes.append(RecordIssue(f"number given as text {text!r}, read as {number:g}",
                                 field=path))
    return number


def _optional_number(obj: dict, key: str, where: str, allow_bool: bool = False) -> None:
    """An optional numeric field: absent or null is fine (and true/false for flags when
    ``allow_bool``); anything else must be a finite number."""
    value = obj.get(key)
    if value is None or allow_bool and isinstance(value, bool):
        return
    _get(obj, key, float, where)


def _read_climate(climate: dict, where: str, notes: list[RecordIssue]) -> None:
    """Climate fields as codes (in place): a code, a code written as text, or its label
    (``"Night"``) are all read, the last two with a note; anything else is an error."""
    for key, table in CLIMATE_CODE_TABLES.items():
        value = climate.get(key)
        if not isinstance(value, str):
            _optional_number(climate, key, where)
            continue
        code = _code_of(value, table)
        if code is None:  # the weather depends on it: a guess would be a silent error
            labels = ", ".join(code_tables()[table].values())
            raise RecordIssue(f"expected number, got str {value!r:.40} (neither a {table} code "
                              f"nor one of its labels: {labels})", field=f"{where}.{key}")
        notes.append(RecordIssue(f"{value!r} read as code {code} ({decode(table, code)})",
                                 field=f"{where}.{key}"))
        climate[key] = code
    _optional_number(climate, "outside_temperature", where)
    for key in CLIMATE_FLAGS:
        value = climate.get(key)
        if isinstance(value, str):
            flag = value.strip().lower() in ("1", "yes", "true", "on")
            notes.append(RecordIssue(f"{value!r} read as {flag}", field=f"{where}.{key}"))
            climate[key] = flag
        _optional_number(climate, key, where, allow_bool=True)


def _code_of(value: object, table: str) -> int | None:
    text = str(value).strip()
    if text.lstrip("-").isdigit():
        return int(text)
    labels = {label.lower(): int(code) for code, label in code_tables()[table].items()}
    return labels.get(text.lower())


def _kind_name(kind: type | tuple[type, ...]) -> str:
    return "number" if kind == (int, float) else getattr(kind, "__name__", str(kind))


def _frames(scene: dict, notes: list[RecordIssue]) -> list[dict]:
    raw = _get(scene, "key_times", list)
    if len(raw) < 2:
        raise RecordIssue(f"needs at least 2 frames, has {len(raw)}", field="key_times")
    frames = []
    previous = None
    for i, frame in enumerate(raw):
        where = f"key_times[{i}]"
        if not isinstance(frame, dict):
            raise RecordIssue("expected an object", field=where)
        t = float(_get(frame, "time", float, where))
        if previous is not None and t <= previous:
            raise RecordIssue(f"time {t} does not increase (previous {previous})",
                              field=f"{where}.time")
        previous = t
        ego = _get(frame, "ego_vehicle", dict, where)
        for key in EGO_FIELDS:
            _get(ego, key, float, f"{where}.ego_vehicle")
        climate = _get(frame, "temporal_climatic", dict, where)
        _read_climate(climate, f"{where}.temporal_climatic", notes)
        obstacles = _get(frame, "obstacles", list, where)
        for j, obstacle in enumerate(obstacles):
            at = f"{where}.obstacles[{j}]"
            if not isinstance(obstacle, dict):
                raise RecordIssue("expected an object", field=at)
            for key in OBSTACLE_FIELDS:
                _get(obstacle, key, float, at)
            for key in OPTIONAL_OBSTACLE_FIELDS:
                _optional_number(obstacle, key, at)
        frames.append(frame)
    return frames


# -- the parts of the record -------------------------------------------------------------------

def _record_part(segment: dict) -> dict:
    """The segment's ``record`` object (who recorded it, when), empty when it has none."""
    record = segment.get("record")
    return record if isinstance(record, dict) else {}


def _scenario_id(code: str, segment: dict, source: str) -> str:
    record = _record_part(segment)
    stamp = re.sub(r"[^0-9T]", "", str(record.get("date_time", "")))[:15] or "undated"
    stem = Path(source).stem.replace(".", "p")
    return f"{code}_{stamp}_{stem}"


def _metadata(segment: dict, source: str, times: list[float], scene: dict) -> dict:
    record = _record_part(segment)
    steps = [b - a for a, b in zip(times, times[1:], strict=False)]
    median = statistics.median(steps)
    regular = max(abs(s - median) for s in steps) <= REGULAR_STEP_TOLERANCE * median
    attributes = _get(scene, "attributes", list) if "attributes" in scene else []
    countries = [a.get("value") for a in attributes
                 if isinstance(a, dict) and a.get("type") == "code_country"]
    return {
        "source_file": source,
        "segment_type": segment.get("type"),
        "campaign": record.get("campaign"),
        "provider": record.get("provider"),
        "recording": record.get("name"),
        "recorded_at": record.get("date_time"),
        "begin_time_s": _get(segment, "begin_time", float, "segment"),
        "end_time_s": _get(segment, "end_time", float, "segment"),
        "duration_s": round(times[-1] - times[0], 3),
        "time_step": {"median_s": round(median, 4), "min_s": round(min(steps), 4),
                      "max_s": round(max(steps), 4), "regular": regular},
        "frames": len(times),
        "country": decode("RT_CountryCode", countries[0]) if countries else None,
    }


def _infrastructure(scene: dict, notes: list[RecordIssue]) -> dict:
    environment = _get(scene, "environment", dict)
    infra = _get(environment, "infrastructure", dict, "environment")
    points = _get(infra, "way_points", list, "environment.infrastructure")
    signs, profile, static = [], [], {}
    for i, point in enumerate(points):
        where = f"environment.infrastructure.way_points[{i}]"
        if not isinstance(point, dict):
            raise RecordIssue("expected an object", field=where)
        at = float(_get(point, "position_longi_from_0", float, where))
        elements = _get(point, "infrastructure_elements", list, where)
        values, sign_codes = {}, []
        for j, element in enumerate(elements):
            at_element = f"{where}.infrastructure_elements[{j}]"
            if not isinstance(element, dict):
                raise RecordIssue("expected an object", field=at_element)
            kind = _get(element, "type", str, at_element)
            if kind == "TrafficSignType":
                sign_codes += _sign_codes(element, at_element, notes)
                continue
            if kind not in NUMERIC_ELEMENTS:
                values[kind] = element.get("value")
                continue
            try:
                values[kind] = _element_value(element, kind, at_element)
            except RecordIssue as issue:  # the road's description only: no scenario needs it
                notes.append(RecordIssue(f"{issue.message}; ignored (no scenario needs it)",
                                         field=issue.field))
        if sign_codes:
            signs.append(_sign(at, sign_codes))
        if "LaneWidth" in values:
            profile.append({"position_m": at, "lane_width_m": values.get("LaneWidth"),
                            "front_curvature": values.get("FrontCurvature"),
                            "rear_curvature": values.get("RearCurvature"),
                            "slope": values.get("Slope")})
        for key in ("SpeedLimit", "RoadType", "NumberOfLanes", "GuardRail", "Junction",
                    "PresenceOfEmergencyLane"):
            if key in values and key not in static:
                static[key] = values[key]
    return {"traffic_signs": signs, "geometry_profile": profile, "static": static}


def _sign_codes(element: dict, where: str, notes: list[RecordIssue]) -> list[float]:
    """A sign's code, or several (a light changing at one way point: ``[170, 172]``)."""
    value = element.get("value")
    if not isinstance(value, list):
        return [_element_value(element, "TrafficSignType", where)]
    notes.append(RecordIssue(f"{len(value)} sign codes at one way point, kept in order",
                             field=f"{where}.value"))
    return [_element_value({"value": v}, "TrafficSignType", f"{where}.value[{k}]")
            for k, v in enumerate(value)]


def _sign(at: float, codes: list[float]) -> dict:
    """One way point's sign; a light's states in the order given, the last one the state the
    record's class is judged by."""
    states = [TRAFFIC_LIGHT_STATES[c] for c in codes if c in TRAFFIC_LIGHT_STATES]
    sign = {"position_m": at, "type_code": codes[-1],
            "label": decode("RT_TrafficSignType", codes[-1]),
            "light_state": states[-1] if states else None}
    if len(codes) > 1:
        sign["light_states"] = states
    return sign


def _element_value(element: dict, kind: str, where: str) -> float:
    """The numeric value of a known way-point element (a coded one may name its label);
    RecordIssue names type and path."""
    value = element.get("value")
    if kind in ELEMENT_CODE_TABLES and isinstance(value, str):
        code = _code_of(value, ELEMENT_CODE_TABLES[kind])
        notes = _NOTES.get()
        if code is not None and not value.strip().lstrip("-").isdigit() and notes is not None:
            notes.append(RecordIssue(f"{value!r} read as code {code}", field=f"{where}.value"))
            element["value"] = code
    try:
        value = _get(element, "value", float, where)
    except RecordIssue as issue:
        raise RecordIssue(f"{kind}: {issue.message}", field=issue.field) from issue
    low = NUMERIC_ELEMENTS[kind]
    if low is not None and value < low:
        raise RecordIssue(f"{kind}: {value} is below {low}", field=f"{where}.value")
    return value


def _environment(first: dict, infra: dict, scene: dict) -> dict:
    climate = first["temporal_climatic"]
    static = infra["static"]
    night = climate.get("day_period") == 2
    rain = climate.get("precipitation", 0) not in (0, None)
    fog = bool(climate.get("fog"))
    weather = "Rain" if rain else ("Fog" if fog else "Clear")
    widths = [p["lane_width_m"] for p in infra["geometry_profile"] if p["lane_width_m"]]
    return {
        "weather_key": f"{'Night' if night else 'Day'}_{weather}",
        "day_period": decode("RT_DayPeriod", climate.get("day_period", 0)),
        "temperature_c": climate.get("outside_temperature"),
        "precipitation": decode("RT_Precipitation", climate.get("precipitation", 0)),
        "fog": fog,
        "dazzled": bool(climate.get("dazzled")),
        "road_type": decode("RT_RoadType", static.get("RoadType", 0)),
        "lane_count": static.get("NumberOfLanes"),
        "speed_limit_kmh": static.get("SpeedLimit"),
        "lane_width_m": round(statistics.median(widths), 3) if widths else None,
        "junction": decode("RT_JunctionBifurcation", static.get("Junction", 0)),
        "guard_rail": decode("RT_GuardRail", static.get("GuardRail", 0)),
        "emergency_lane": decode("RT_PresenceOfEmergencyLane",
                                 static.get("PresenceOfEmergencyLane", 0)),
    }


def _ego_state(frame: dict) -> dict:
    ego = frame["ego_vehicle"]
    return {
        "time_s": frame["time"],
        "speed_ms": round(ego["ego_speed"] / 3.6, 4),
        "acceleration_ms2": ego["longitudinal_acceleration_wheels"],
        "steer_deg": ego["steer_wheel_angle"],
        "braking": ego["ego_brake"] != 0,
        "lane": ego["ego_lane"],
        "turning_signal": decode("RT_TurningSignalState", ego["turning_signal_state"]),
    }


def _ego_trajectory(frames: list[dict]) -> dict:
    t0 = frames[0]["time"]
    odo0 = frames[0]["ego_vehicle"]["covered_distance_by_ego"]
    centre0 = _lane_centre_offset(frames[0]["ego_vehicle"])
    return {
        "t": [round(f["time"] - t0, 4) for f in frames],
        "ds": [round(f["ego_vehicle"]["covered_distance_by_ego"] - odo0, 3) for f in frames],
        "dl": [round(_lane_centre_offset(f["ego_vehicle"]) - centre0, 3) for f in frames],
        "v": [round(f["ego_vehicle"]["ego_speed"] / 3.6, 4) for f in frames],
        "yaw_rate": [f["ego_vehicle"]["yaw_rate"] for f in frames],
    }


def _lane_centre_offset(ego: dict) -> float:
    # markings: left is negative, right positive; their midpoint is the ego's offset from centre
    return -(ego["dist_to_marking_left"] + ego["dist_to_marking_right"]) / 2


def _role(obstacle: dict) -> str:
    if obstacle["mobile_object_classification"] == 4:
        return "pedestrian"
    if obstacle["absolute_velocity_x"] < -1.0:
        return "oncoming"
    lane = obstacle["obstacle_relative_lane"]
    if lane == 0 and obstacle["pos_x"] > 0:
        return "lead_vehicle"
    toward_ego = -lane * obstacle.get("relative_velocity_y", 0.0) > 0.3
    blinking_toward = obstacle.get("blinker") == (2 if lane < 0 else 1)
    if abs(lane) == 1 and abs(obstacle["pos_x"]) < 50 and (toward_ego or blinking_toward):
        return "adversary"
    return "background"


def _actor_state(obstacle: dict, role: str | None = None) -> dict:
    ttc = obstacle.get("time_to_collision")
    return {
        "id": obstacle["unique_id"],
        "role": role or _role(obstacle),
        "classification": decode("RT_MobileObjectClassification",
                                 obstacle["mobile_object_classification"]),
        "pos_x_m": obstacle["pos_x"],
        "pos_y_m": obstacle["pos_y"],
        "speed_ms": obstacle["absolute_velocity_x"],
        "rel_speed_ms": obstacle["relative_velocity_x"],
        "relative_lane": obstacle["obstacle_relative_lane"],
        "blinker": decode("RT_Blinker", obstacle.get("blinker", 0)),
        "ttc_s": ttc if isinstance(ttc, int | float) and ttc > 0 else None,
    }


def _actors(frames: list[dict], ego_ds: list[float]) -> tuple[list[dict], list[dict]]:
    """Actors at their first sighting (one lead: the nearest) and their trajectories."""
    first_seen: dict[Any, tuple[int, dict]] = {}
    for i, frame in enumerate(frames):
        for obstacle in frame["obstacles"]:
            first_seen.setdefault(obstacle["unique_id"], (i, obstacle))
    states = [_actor_state(o) for _, o in first_seen.values()]
    leads = sorted((s for s in states if s["role"] == "lead_vehicle"), key=lambda s: s["pos_x_m"])
    for extra in leads[1:]:
        extra["role"] = "background"
    roles = {s["id"]: s["role"] for s in states}
    tracks = [_actor_track(uid, roles[uid], frames, ego_ds) for uid in first_seen]
    at_start = [s for s in states if first_seen[s["id"]][0] == 0]
    return at_start, tracks


def _actor_track(uid: Any, role: str, frames: list[dict], ego_ds: list[float]) -> dict:
    t0 = frames[0]["time"]
    t, ds, dl, v_rel, v = [], [], [], [], []
    start = None
    for frame, ego_s in zip(frames, ego_ds, strict=True):
        obstacle = next((o for o in frame["obstacles"] if o["unique_id"] == uid), None)
        if obstacle is None:
            continue
        along, across = ego_s + obstacle["pos_x"], obstacle["pos_y"]
        start = start or (along, across)
        t.append(round(frame["time"] - t0, 4))
        ds.append(round(along - start[0], 3))
        dl.append(round(across - start[1], 3))
        v_rel.append(obstacle["relative_velocity_x"])
        v.append(obstacle["absolute_velocity_x"])
    return {"id": uid, "role": role, "t": t, "ds": ds, "dl": dl, "v_rel": v_rel, "v": v}


def _min_ttc(frames: list[dict]) -> float | None:
    values = [o.get("time_to_collision") for f in frames for o in f["obstacles"]]
    positive = [v for v in values if isinstance(v, int | float) and v > 0]
    return round(min(positive), 3) if positive else None


def _summary(ego: dict) -> dict:
    v = ego["v"]
    stop_time = next((t for t, speed in zip(ego["t"], v, strict=True) if speed <= 0.1), None)
    return {
        "speed_min_ms": min(v), "speed_max_ms": max(v),
        "speed_mean_ms": round(sum(v) / len(v), 4), "initial_speed_ms": v[0],
        "final_speed_ms": v[-1], "drive_distance_m": ego["ds"][-1],
        "stopped": stop_time is not None, "stop_time_s": stop_time,
    }


def _tags(code: str, environment: dict, actors: list[dict]) -> list[str]:
    tags = [maneuvers.get(code).tag, environment["weather_key"].lower()]
    tags += sorted({a["role"] for a in actors if a["role"] != "background"})
    return tags


def _slug(label: str) -> str:
    first = label.split("/")[0].strip().lower()
    return re.sub(r"[^a-z0-9]+", "_", first).strip("_") or "unknown"


def describe(record: dict) -> str:
    """The deterministic two-sentence description (an LLM may replace it when configured)."""
    code = record["maneuver_class"]
    env = record["environment"]
    v0 = record["initial_state"]["ego"]["speed_ms"] * 3.6
    lights = [s for s in record["infrastructure"]["traffic_signs"] if s["light_state"]]
    light = lights[0] if lights else None
    road = env["road_type"].split("/")[0].strip().lower()
    weather = env["weather_key"].replace("_", ", ").lower()
    maneuver = maneuvers.get(code)
    if light and maneuver.light is not None:
        action = (f"{maneuver.verb} the {light['light_state']} traffic light "
                  f"{light['position_m']:.0f} m ahead")
    else:
        action = "keeps its lane"
    article = "an" if road[:1] in "aeiou" else "a"
    first = (f"{maneuver.name} on {article} {road} ({weather}): the ego starts at "
             f"{v0:.0f} km/h and {action}.")
    return f"{first} {_actors_sentence(record['initial_state']['actors'])}"


def _actors_sentence(actors: list[dict]) -> str:
    parts = []
    for actor in actors:
        if actor["role"] == "lead_vehicle":
            parts.append(f"a lead {actor['classification'].lower()} {actor['pos_x_m']:.0f} m ahead "
                         f"at {actor['speed_ms'] * 3.6:.0f} km/h")
        elif actor["role"] == "pedestrian":
            parts.append("a pedestrian")
        elif actor["role"] in ("oncoming", "adversary"):
            parts.append(f"an {actor['role']} {actor['classification'].lower()}")
    if not parts:
        return "No other road user takes part."
    return f"Also present: {', '.join(parts)}."

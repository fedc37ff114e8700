"""Canonical record -> flat params dict (thesis Tables 5.1, 5.2; contract in docs/params.md).

Each extractor reads the record's primary quantities; ``_finish`` then derives what follows
from them (end speeds, timeout, the spawn footprint), so perturbed variants stay consistent.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping
from typing import Any

from scenweave import maneuvers
from scenweave.ingest.issues import RecordIssue
from scenweave.ingest.layouts import default_layouts
from scenweave.ingest.phases import SPEED_TOL_MS, NoProfile, fit_end_values, fit_series
from scenweave.maneuvers.free_ride import SLOTS
from scenweave.maneuvers.maneuver import RecordFieldError, SameLane
from scenweave.scenario_lib.phases import PHASED_ACTORS, is_single_ramp, profile_of
from scenweave.scenario_lib.vehicles import least_reference_gap_m, reference_gap_m
from scenweave.schemas.params import Params, ParamsInvalid, checked

HIGHWAY_MANEUVER_START_S = 2.0
TIMEOUT_FACTOR = 2.5
YELLOW_DELAY_BOUNDS_S = (1.0, 8.0)
YELLOW_POINT_BEFORE_LIGHT_M = 5.0
STOPPED_BELOW_MS = 0.1
HIGHWAY_WEATHER = "Day_Clear"
#: a recorded series whose first speed differs more from the params' start speed is not the
#: record's (a perturbed variant) (m/s)
SERIES_START_TOL_MS = 1.0
#: a mined lane change as its lateral position recorded it (mining.highway.lateral_fields):
#: copied from the record's params, kept only while its series is (docs/params.md)
LANE_CHANGE_KEYS = ("lane_change_cross_s", "lane_change_width_m")
SPAWN_KEYS = ("spawn_id", "ego_x", "ego_y", "ego_z", "ego_h", "ego_road_id", "ego_lane_id",
              "ego_s")


def extract_params(record: dict) -> Params:
    """The flat params dict of one canonical record, highway or urban."""
    if record.get("domain") == "highway":
        return _extract_highway(record)
    if str(record.get("version", "")).startswith("urban."):
        return _extract_urban(record)
    raise RecordIssue("not a canonical record (neither highway phase1.v1 nor urban.v1)",
                      field="schema_version")


# -- highway -----------------------------------------------------------------------------------

def _extract_highway(record: dict) -> Params:
    code = record["maneuver_class"]
    maneuver = maneuvers.find(code)
    if maneuver is None or maneuver.domain != "highway":
        raise RecordIssue(f"unknown highway class {code!r} (known: "
                          f"{', '.join(maneuvers.codes('highway'))})", field="maneuver_class")
    if maneuver.extract is None:  # never: Maneuver requires one of a highway class
        raise RecordIssue(f"class {code!r} has no extract function", field="maneuver_class")
    raw = record["params"]
    conventions = record_conventions(record)
    base = {
        "scenario_id": record["scenario_id"],
        "maneuver_class": code,
        "maneuver_tag": record["maneuver_tag"],
        "domain": "highway",
        "weather_key": HIGHWAY_WEATHER,
        "maneuver_start_s": HIGHWAY_MANEUVER_START_S,
        "duration_s": raw["duration_s"],
        "other_dir_traffic": raw.get("other_dir_traffic") == "Yes",
        "has_npc": bool(record["has_npc"]),
        "npc_position": record["npc_position"],
    }
    try:
        base.update(maneuver.extract(raw, code, conventions))
    except KeyError as err:
        raise RecordIssue("missing in params", field=f"params.{err.args[0]}") from err
    except RecordFieldError as err:
        raise RecordIssue(str(err), field=err.field) from err
    if conventions.get("gaps_between", "reference_points") == "bumpers":
        _gaps_to_reference_points(base)
    series = record.get("series")
    if isinstance(series, dict) and isinstance(series.get("t"), list):
        base["recorded_series"] = {k: list(v) for k, v in series.items() if isinstance(v, list)}
        base.update(_recorded_lane_change(raw, base, maneuver.lane_change))
        base["maneuver_start_s"] = lead_in_s(base, maneuver.same_lane)
    base.update(dict.fromkeys(SPAWN_KEYS))
    return finish(base)


def lead_in_s(params: Mapping[str, Any], same_lane: SameLane | None) -> float:
    """How long a mined record's cars drive at their start speeds before the manoeuvre:
    ``HIGHWAY_MANEUVER_START_S``, or shorter where a car of the ego's lane would otherwise
    start with the bumpers closer than ``MIN_BUMPER_GAP_M`` (issue 36: in town a car 7.8 m
    behind at 2.8 m/s, the ego at 5.1 m/s, stood 4.6 m closer 2 s earlier, on the ego's
    boot: a collision at 0.00 s). 0 when even the record's start is too close (which
    ``check_playable`` then says)."""
    longest = HIGHWAY_MANEUVER_START_S
    if same_lane is None:
        return longest
    prefix = same_lane.prefix
    if not params.get("has_npc" if prefix == "npc" else f"{prefix}_present"):
        return longest
    gap, speed = params.get(f"{prefix}_distance_m"), params.get(f"{prefix}_speed_ms")
    if not isinstance(gap, float | int) or not isinstance(speed, float | int):
        return longest
    ahead = math.copysign(1.0, gap) > 0
    room = least_reference_gap_m(params.get(f"{prefix}_vehicle_type"), ahead)
    closing = (speed - params["ego_speed_ms"]) * (1.0 if ahead else -1.0)  # m/s, lead-in
    spare = abs(gap) - room
    if closing <= 0 or spare >= closing * longest:
        return longest
    return max(0.0, math.floor(10 * spare / closing) / 10)


def _recorded_lane_change(raw: Mapping[str, Any], params: Mapping[str, Any],
                          changer: str | None) -> dict[str, float]:
    """A mined lane change's crossing time and lane spacing, and where the changer starts
    across its lane (``<actor>_lane_offset_m``, + to the left of its travel; the record gives
    it toward the new lane); nothing for a MOOVE row, which keeps its duration only."""
    found = {key: float(raw[key]) for key in (*LANE_CHANGE_KEYS, "lane_change_offset_m")
             if isinstance(raw.get(key), float | int) and not isinstance(raw.get(key), bool)}
    if changer is None or len(found) != len(LANE_CHANGE_KEYS) + 1:
        return {}
    toward_left = 1.0 if params.get("lane_change_direction") == "left" else -1.0
    offset = found.pop("lane_change_offset_m") * toward_left
    return found | {f"{'ego' if changer == 'hero' else 'npc'}_lane_offset_m": offset}


def _gaps_to_reference_points(params: dict) -> None:
    """Bumper gaps of the file -> the reference-point gaps params hold (docs/params.md)."""
    for prefix in ("npc", *SLOTS):
        kind = params.get(f"{prefix}_vehicle_type")
        for key in gap_keys(prefix):
            present = prefix == "npc" or params.get(f"{prefix}_present")
            if present and isinstance(params.get(key), float | int):
                params[key] = reference_gap_m(params[key], kind)


def gap_keys(prefix: str) -> tuple[str, ...]:
    """The params keys holding the gaps between the ego and the highway actor ``prefix``."""
    if prefix not in ("npc", *SLOTS):
        return ()
    return f"{prefix}_distance_m", f"{prefix}_end_distance_m", f"{prefix}_distance_end_m"


def record_conventions(record: dict) -> dict:
    """The layout conventions the record was read with (sign, gap convention, sentinels);
    records written without them (other tools) get the bundled layout's. Records of older
    ingests carry conventions without ``gaps_between``: their gaps were taken as reference
    points then, and still are."""
    conventions = record.get("conventions")
    if isinstance(conventions, dict):
        return conventions
    layout = default_layouts().classes.get(record["maneuver_class"])
    return layout.conventions if layout else {}


# -- urban -------------------------------------------------------------------------------------

def _extract_urban(record: dict) -> Params:
    trajectory = record["dynamic_content"]["ego_trajectory"]
    t, ds, v = trajectory["t"], trajectory["ds"], trajectory["v"]
    env = record["environment"]
    light = next((s for s in record["infrastructure"]["traffic_signs"] if s["light_state"]), None)
    tfl_ds = light["position_m"] if light else None
    lead = next((a for a in record["initial_state"]["actors"] if a["role"] == "lead_vehicle"),
                None)
    oncoming = next((a for a in record["initial_state"]["actors"] if a["role"] == "oncoming"),
                    None)
    roles = {a["role"] for a in record["initial_state"]["actors"]}
    params = {
        "scenario_id": record["scenario_id"],
        "maneuver_class": record["maneuver_class"],
        "maneuver_tag": record["maneuver_tag"],
        "domain": "urban",
        "road_type": record["domain"],
        "weather_key": env["weather_key"],
        "maneuver_start_s": 0.0,
        "duration_s": t[-1] - t[0],
        "ego_speed_ms": v[0],
        "ego_end_speed_ms": v[-1],
        "brake_time_s": brake_time(t, v),
        "yellow_delay_s": yellow_delay(t, ds, v[0], tfl_ds),
        "drive_distance_m": ds[-1] - ds[0],
        "tfl_ds_m": tfl_ds,
        "tfl_state": light["light_state"] if light else None,
        "turn": maneuvers.get(record["maneuver_class"]).turn,
        "speed_limit_kmh": env["speed_limit_kmh"],
        "lane_count": _whole(env["lane_count"]),
        "lane_width_m": env["lane_width_m"],
        "has_npc": lead is not None,
        "npc_position": "front" if lead else None,
        "lead_present": lead is not None,
        "lead_distance_m": _lead_reference_gap(lead),
        "lead_speed_ms": lead["speed_ms"] if lead else 0.0,
        "lead_vehicle_type": lead["classification"].lower() if lead else None,
        "oncoming_present": oncoming is not None,
        "oncoming_distance_m": oncoming["pos_x_m"] if oncoming else 0.0,
        "oncoming_speed_ms": abs(oncoming["speed_ms"]) if oncoming else 0.0,
        "oncoming_vehicle_type": oncoming["classification"].lower() if oncoming else None,
        "pedestrian_present": "pedestrian" in roles,
        "min_ttc_s": record["semantics"]["criticality_metric"]["min_ttc_s"],
        **record["perturbation"],
    }
    series = record.get("series")
    if isinstance(series, dict) and isinstance(series.get("t"), list) \
            and not maneuvers.get(record["maneuver_class"]).stops_at_line:
        # a stop at red is played to the map's stop line, not on the recorded clock
        params["recorded_series"] = {k: list(v) for k, v in series.items()
                                     if isinstance(v, list)}
    params.update(dict.fromkeys(SPAWN_KEYS))
    return finish(params)


def _lead_reference_gap(lead: Mapping[str, Any] | None) -> float:
    """The lead's reference-point distance ahead of the ego: ADScene's ``pos_x`` is the free
    space a sensor measures to the lead's rear bumper (mined records write the bumper gap,
    ``mining.lights.frame_of``); placed as a reference-point distance, a lead 2.5 m ahead in
    a queue stood on the ego's bonnet (issue 36: 7 collisions at 0.00 s)."""
    if lead is None:
        return 0.0
    return reference_gap_m(lead["pos_x_m"], lead["classification"].lower())


def _whole(count: float | None) -> int | None:
    """A count the record gave as a number (``2.0``) as an int; None when it gave none or
    no whole one (no stage needs the lane count: docs/params.md)."""
    return int(count) if isinstance(count, int | float) and float(count).is_integer() else None


def brake_time(t: list[float], v: list[float]) -> float:
    """Time of the first frame at or below 0.1 m/s; the whole span if the ego never stops."""
    for time, speed in zip(t, v, strict=True):
        if speed <= STOPPED_BELOW_MS:
            return time - t[0]
    return t[-1] - t[0]


def yellow_delay(t: list[float], ds: list[float], v0: float, tfl_ds: float | None) -> float | None:
    """Time for the ego to reach 5 m before the light, clamped to [1, 8] s (None: no light)."""
    if tfl_ds is None:
        return None
    target = tfl_ds - YELLOW_POINT_BEFORE_LIGHT_M
    reached = _time_at_distance(t, ds, target)
    if reached is None:
        reached = target / v0 if v0 > 0 else YELLOW_DELAY_BOUNDS_S[1]
    low, high = YELLOW_DELAY_BOUNDS_S
    return min(max(reached, low), high)


def _time_at_distance(t: list[float], ds: list[float], target: float) -> float | None:
    if target <= ds[0]:
        return t[0] - t[0]
    for i in range(1, len(ds)):
        if ds[i] >= target:
            share = (target - ds[i - 1]) / (ds[i] - ds[i - 1]) if ds[i] > ds[i - 1] else 1.0
            return t[i - 1] + share * (t[i] - t[i - 1]) - t[0]
    return None


# -- derived values, shared by both domains and by variants -----------------------------------

def finish(params: dict) -> Params:
    """Fill the values that follow from the primary ones and check the result against the
    params contract (``schemas.check_params``); returns ``params`` (changed in place)."""
    if "delta_speed_ms" in params:
        params["npc_end_speed_ms"] = max(params["npc_speed_ms"] + params["delta_speed_ms"], 0.0)
    maneuver = maneuvers.get(params["maneuver_class"])
    if maneuver.ego_end_speed_factor is not None:
        params["ego_end_speed_ms"] = params["ego_speed_ms"] * maneuver.ego_end_speed_factor
    if params["domain"] == "urban":  # thesis Table 5.1 names, same values (docs/params.md)
        params["init_speed_ms"] = params["ego_speed_ms"]
        params["final_speed_ms"] = params["ego_end_speed_ms"]
    params["timeout_s"] = TIMEOUT_FACTOR * (params["maneuver_start_s"] + params["duration_s"])
    params["required_lane_sides"] = maneuver.lane_sides(params)
    fit_phases(params)
    speeds = [v for k, v in params.items() if k.endswith("speed_ms") and isinstance(v, float)]
    speeds += [p["target_ms"] for k in PHASED_ACTORS for p in params.get(f"{k}_phases") or ()]
    params["max_speed_ms"] = max(speeds, default=0.0)
    gaps = _start_gaps(params)
    params["gap_ahead_m"] = max([g for g in gaps if g > 0], default=0.0)
    params["gap_behind_m"] = max([-g for g in gaps if g < 0], default=0.0)
    try:
        return checked(params)
    except ParamsInvalid as err:
        raise RecordIssue(str(err), field=err.key and f"params.{err.key}") from err


def fit_phases(params: dict) -> None:
    """``<actor>_phases`` where one ramp does not show the record (docs/params.md): fitted to
    the recorded series when the record has one that starts at the params' speeds, else, for
    a class whose end gap is recorded, the smallest profile that meets it (none when no
    profile can: ``check_playable`` says why)."""
    for prefix in PHASED_ACTORS:
        params.pop(f"{prefix}_phases", None)
    series = params.get("recorded_series")
    if series is not None and not _series_starts_at_params(params, series):
        del params["recorded_series"]  # a perturbed variant: no longer what was recorded
        for key in (*LANE_CHANGE_KEYS, "ego_lane_offset_m", "npc_lane_offset_m"):
            params.pop(key, None)
        series = None
    if series is not None:
        for prefix in PHASED_ACTORS:  # the ego first: the others keep their gap to it
            speeds = series.get(f"{prefix}_speed_ms")
            if speeds and isinstance(params.get(f"{prefix}_speed_ms"), int | float):
                _keep(params, prefix, _fit_actor(params, series, prefix))
        return
    if maneuvers.get(params["maneuver_class"]).gap_at_end:
        with contextlib.suppress(NoProfile):
            _keep(params, "npc", npc_end_gap_phases(params))


def _fit_actor(params: Mapping[str, Any], series: dict, prefix: str) -> tuple:
    """``prefix``'s phases from the series, keeping its gap to the ego too where that does
    not take many more phases (a recorded gap that disagrees with the recorded motion, e.g.
    measured across lanes, would otherwise cost a phase per sample)."""
    # past tracking noise the recorded positions may stay off (the tracker's box moved):
    # an actor with noise keeps the distance its own speeds drive, not its positions
    positions = None if _noise_from(series, (prefix,)) is not None \
        else series.get(f"{prefix}_s_m")
    args = (series["t"], series[f"{prefix}_speed_ms"], params["maneuver_start_s"],
            params[f"{prefix}_speed_ms"], positions)
    targets = _gap_targets(params, series, prefix)
    if targets is None:
        return fit_series(*args)
    with_gap = fit_series(*args, targets)
    if len(with_gap) <= 2:
        return with_gap  # within twice the own fit's phases plus two, however few those are
    own = fit_series(*args)
    return with_gap if len(with_gap) <= 2 * len(own) + 2 else own


def _gap_targets(params: Mapping[str, Any], series: dict, prefix: str) -> list[float | None] | None:
    """The distance ``prefix`` must have driven since its first speed sample at each sample
    for its recorded gap to the ego to hold: what it had driven when the gap was first
    measured, plus the ego's fitted distance since then and the gap's change (None: no gap
    recorded)."""
    # a gap of 0 is no measurement: the cars are side by side (no facing bumpers); past the
    # first change of sign other bumpers face each other (the gap jumps by both lengths)
    gaps = [None if g == 0 else g for g in series.get(f"{prefix}_gap_m") or ()]
    sign = next((g > 0 for g in gaps if g is not None), None)
    passed = next((k for k, g in enumerate(gaps) if g is not None and (g > 0) != sign), None)
    if passed is not None:
        gaps = [*gaps[:passed], *[None] * (len(gaps) - passed)]
    noisy = _noise_from(series, ("ego", prefix))  # a gap past tracking noise may stay off
    if noisy is not None:
        gaps = [*gaps[:noisy], *[None] * (len(gaps) - noisy)]
    times = series["t"]
    measured = [(t, g) for t, g in zip(times, gaps, strict=False)
                if t is not None and g is not None]
    own = _recorded_distance(series, prefix)
    if prefix == "ego" or not measured or own is None:
        return None
    ego, start = profile_of(params, "ego"), params["maneuver_start_s"]
    (t1, first), base = measured[0], ego.distance(start + measured[0][0])
    driven = own(t1)
    return [None if g is None or t is None else driven + ego.distance(start + t) - base
            + g - first for t, g in zip(times, gaps, strict=False)]


def _recorded_distance(series: dict, prefix: str):
    """``t -> `` what ``prefix`` drove from its first speed sample to sample time ``t``, by its
    recorded positions where it has them, else by its speeds (None: no speeds)."""
    rows = [(t, v, x) for t, v, x in zip(series["t"], series.get(f"{prefix}_speed_ms") or (),
                                         series.get(f"{prefix}_s_m") or [None] * len(series["t"]),
                                         strict=False) if t is not None and v is not None]
    if not rows:
        return None
    with_positions = all(x is not None for _, _, x in rows)
    table, total = {}, 0.0
    for k, (t, v, x) in enumerate(rows):
        if with_positions:
            total = x - rows[0][2]
        elif k:
            total += (v + rows[k - 1][1]) / 2 * (t - rows[k - 1][0])
        table[t] = total
    return lambda t: table.get(t, 0.0)


def _noise_from(series: Mapping[str, Any], roles: tuple[str, ...]) -> int | None:
    """The first sample any of ``roles`` has tracking noise at (mining's ``<role>_noise``),
    None when none has."""
    marks = [k for role in roles for k, n in enumerate(series.get(f"{role}_noise") or ()) if n]
    return min(marks, default=None)


def npc_end_gap_phases(params: Mapping[str, Any]) -> tuple:
    """The NPC's profile that meets its recorded end gap while the ego drives its ramp
    (``ingest.phases.fit_end_values``; raises ``NoProfile``)."""
    duration = params["duration_s"]
    ego_m = (params["ego_speed_ms"] + params["ego_end_speed_ms"]) / 2 * duration
    needed = ego_m + params["npc_distance_end_m"] - params["npc_distance_m"]
    return fit_end_values(params["npc_speed_ms"], params["npc_end_speed_ms"],
                          params["maneuver_start_s"], duration, needed)


def _keep(params: dict, prefix: str, phases: tuple) -> None:
    """``<prefix>_phases`` unless they are the single ramp params describe anyway."""
    records = [p.record() for p in phases]
    params[f"{prefix}_phases"] = records
    holds = not records and abs(params[f"{prefix}_end_speed_ms"] - params[f"{prefix}_speed_ms"]) \
        <= SPEED_TOL_MS  # the ramp from start to end speed is a hold within the tolerance
    if holds or is_single_ramp(params, prefix):
        del params[f"{prefix}_phases"]


def _series_starts_at_params(params: Mapping[str, Any], series: dict) -> bool:
    for prefix in PHASED_ACTORS:
        speeds = [v for v in series.get(f"{prefix}_speed_ms") or () if v is not None]
        start = params.get(f"{prefix}_speed_ms")
        if speeds and isinstance(start, int | float) \
                and abs(speeds[0] - start) > SERIES_START_TOL_MS:
            return False
    return True


def _start_gaps(params: Mapping[str, Any]) -> list[float]:
    keys = ["npc_distance_m", "lead_distance_m", *(f"{s}_distance_m" for s in SLOTS)]
    return [float(params[k]) for k in keys if isinstance(params.get(k), int | float)]

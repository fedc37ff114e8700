"""What the page needs to show one played scenario, computed on the server from its folder.

``scene(folder)`` reads ``replay.json`` (``player.Playback``: every actor's pose and speed per
step, its box, the lights' actions and where they stand, the map played on) and, where they
are there, ``params.json`` (the record's values), ``scenario.xosc`` (the scripted speed
changes) and the mined record's ``recorded.json``. The animation needs only ``replay.json``;
the judge's verdict (``verdict.json``, written beside it by whatever played the scenario,
``scenweave replay --force`` included) adds what the judge expected of the replay (start
speeds, speed targets, gaps, with their tolerance), what it observed and its findings at
their times. The viewer draws that verdict; it does not judge.

Everything is plain JSON: lanes are polylines sampled from the OpenDRIVE map by ``roads``
(the one reader of the map), the gap curves are measured along the lanes as the judge
measures them (``judge.replay.gap_along_lane``).
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from scenweave.judge.replay import ROLE_ENTITIES, gap_series, light_state
from scenweave.player import Playback
from scenweave.scenario_lib.vehicles import reference_gap_m
from scenweave.schemas.params import Params, finite, unchecked
from scenweave.schemas.scenario_folder import (
    PARAMS_NAME,
    RECORDED_NAME,
    REPLAY_NAME,
    STATUS_NAME,
    ReplayVerdict,
    VerdictMark,
    read_json_object,
    read_verdict,
)

EGO = "hero"
#: the gap chart is sampled this often (s); each sample follows the lanes (~1 ms)
GAP_STEP_S = 0.2
#: metres of map drawn around the paths
MAP_MARGIN_M = 40.0
#: lane borders are sampled about this far apart (m)
LANE_STEP_M = 2.0


def scene(folder: Path) -> dict[str, Any]:
    """The scenario in ``folder`` as the page animates and charts it (``KeyError``-free: a
    missing file leaves its part out; no ``replay.json`` gives ``played: False``)."""
    params = unchecked(read_json_object(folder / PARAMS_NAME))
    status = read_json_object(folder / STATUS_NAME)
    replay_path = folder / REPLAY_NAME
    out: dict[str, Any] = {"scenario_id": params.get("scenario_id") or status.get("scenario_id")
                           or folder.name,
                           "maneuver_class": params.get("maneuver_class")
                           or status.get("maneuver_class"),
                           "domain": params.get("domain") or status.get("domain"),
                           "played": False}
    if not replay_path.is_file():
        out["problem"] = "not played: no replay.json in the folder"
        return out
    raw = read_json_object(replay_path)
    playback = Playback.from_dict(raw)
    if playback.engine_error or not playback.times:
        out["problem"] = playback.engine_error or "esmini recorded no step"
        out["log"] = playback.log[-10:]
        return out
    map_path = _map_path(playback.map or params.get("map"))
    verdict = read_verdict(folder)
    out.update(played=True, duration_s=playback.duration_s, times=playback.times,
               actors=_actors(playback), lights=_lights(playback, params),
               collisions=[list(c) for c in playback.collisions],
               lanes=_lanes_near(map_path, playback),
               map=Path(map_path).stem if map_path else None,
               charts=_charts(playback, params, folder, map_path, verdict),
               findings=_findings(verdict, status),
               series_errors=_series_errors(raw, status))
    return out


def _map_path(name: str | None) -> Path | None:
    from scenweave import roads

    if name and Path(name).is_file():
        return Path(name)
    try:
        return roads.resolve_map(Path(name).stem if name else None).path
    except roads.UnknownMapError:
        return None


# --- the animation ---------------------------------------------------------------------------

def _actors(playback: Playback) -> dict[str, dict]:
    actors = {}
    for name, track in playback.tracks.items():
        box = playback.boxes.get(name)
        actors[name] = {key: track[key] for key in ("x", "y", "h", "speed", "lane",
                                                    "lane_offset", "road")}
        actors[name]["box"] = ([box.length, box.width, box.center_ahead] if box
                               else [4.5, 1.9, 1.4])
    return actors


def _lights(playback: Playback, params: Params) -> list[dict]:
    """Each light of the scenario: where it stands and its colour from when to when (a
    replay.json written before it said where lights stand: the params' light, CARLA frame)."""
    started = playback.fired("action")
    changes = sorted((t, name) for name, t in started.items() if name in playback.lights)
    spans = [[t, changes[i + 1][0] if i + 1 < len(changes) else playback.duration_s,
              playback.lights[name]] for i, (t, name) in enumerate(changes)]
    positions = {tuple(xy) for xy in playback.light_positions.values()}
    x_carla, y_carla = finite(params.get("tfl_x_carla")), finite(params.get("tfl_y_carla"))
    if not positions and spans and x_carla is not None and y_carla is not None:
        positions = {(x_carla, -y_carla)}
    return [{"x": x, "y": y, "spans": spans} for x, y in sorted(positions)]


def _lanes_near(map_path: Path | None, playback: Playback) -> list[dict]:
    """The map's drivable lane borders within ``MAP_MARGIN_M`` of the paths."""
    if map_path is None:
        return []
    xs = [x for track in playback.tracks.values() for x in track["x"]]
    ys = [y for track in playback.tracks.values() for y in track["y"]]
    box = (min(xs) - MAP_MARGIN_M, max(xs) + MAP_MARGIN_M,
           min(ys) - MAP_MARGIN_M, max(ys) + MAP_MARGIN_M)
    near = []
    for bounds, junction, points in _lane_polylines(str(map_path)):
        if bounds[0] <= box[1] and bounds[1] >= box[0] and bounds[2] <= box[3] \
                and bounds[3] >= box[2]:
            near.append({"junction": junction, "points": points})
    return near


@lru_cache(maxsize=4)
def _lane_polylines(map_path: str) -> list[tuple[tuple[float, ...], bool, list[list[float]]]]:
    """(x0, x1, y0, y1), in a junction, [[x, y], ...] of both borders of every drivable lane
    section of the map (once per map and process)."""
    from scenweave import roads

    return [(line.bounds, line.in_junction, np.round(line.points, 2).tolist())
            for line in roads.road_network(map_path).border_lines(LANE_STEP_M)]


# --- the charts ------------------------------------------------------------------------------

def _charts(playback: Playback, params: Params, folder: Path, map_path: Path | None,
            verdict: ReplayVerdict | None) -> dict:
    """Speed, gap, lateral offset and lane, light state: the replay's series, what the judge
    expected with its tolerance (its verdict), and the mined record's own series where there
    is one."""
    recorded = _recorded(folder, params)
    tolerances = verdict["tolerances"] if verdict else None
    return {
        "speed": {"series": {n: t["speed"] for n, t in playback.tracks.items()},
                  "marks": _marks(verdict["speed_marks"] if verdict else []),
                  "tol": tolerances["speed_ms"] if tolerances else None,
                  "series_tol": tolerances["series_speed_ms"] if tolerances else None,
                  "recorded": {f"{e}": recorded[f"{r}_speed_ms"] for r, e in
                               (("ego", EGO), ("npc", "npc")) if f"{r}_speed_ms" in recorded},
                  "recorded_t": recorded.get("t")},
        "gap": _gap_chart(playback, params, recorded, map_path, verdict),
        "lateral": {"offset": {n: t["lane_offset"] for n, t in playback.tracks.items()},
                    "lane": {n: t["lane"] for n, t in playback.tracks.items()},
                    "recorded": _recorded_offsets(playback, recorded),
                    "recorded_t": recorded.get("t"),
                    "tol_s": tolerances["lane_change_s"] if tolerances else None},
        "light": [light_state(playback, t) for t in playback.times] if playback.lights else [],
        "maneuver": [finite(params.get("maneuver_start_s")), finite(params.get("duration_s"))],
        "stop_line": _stop_line_chart(playback, params),
    }


def _recorded_offsets(playback: Playback, recorded: dict) -> dict[str, list[float | None]]:
    """Each car's recorded offset from the centre of its lane (a mined record's
    ``<role>_lane_offset_m``, + left of its travel) in the frame the played offset is drawn
    in: OpenDRIVE's ``t``, turned for a car in a positive lane (driving against ``s``)."""
    found = {}
    for role, entity in ROLE_ENTITIES.items():
        values = recorded.get(f"{role}_lane_offset_m")
        if not isinstance(values, list) or entity not in playback.tracks:
            continue
        turn = 1 if playback.tracks[entity]["lane"][0] < 0 else -1
        found[entity] = [None if v is None else v * turn for v in values]
    return found


def _marks(marks: list[VerdictMark]) -> list[dict]:
    """The verdict's marks as the page draws them: the record's value at its time, with the
    judge's tolerance, and what the replay showed."""
    return [{"entity": m["entity"], "t": m["t"], "value": m["expected"], "tol": m["tol"],
             "what": m["what"], "observed": m["observed"]} for m in marks]


def _driven(playback: Playback, entity: str) -> np.ndarray:
    """Metres ``entity`` has driven at every sample (the trapezoid the judge sums)."""
    speeds, times = np.asarray(playback.tracks[entity]["speed"]), np.asarray(playback.times)
    return np.concatenate([[0.0], np.cumsum((speeds[1:] + speeds[:-1]) / 2 * np.diff(times))])


def _stop_line_chart(playback: Playback, params: Params) -> dict:
    """Urban: the ego's distance driven against the record's stop line, and where that line
    lies on the ego's path (across it, for the map)."""
    stop_line = finite(params.get("spawn_stop_line_distance_m"))
    if stop_line is None or EGO not in playback.tracks:
        return {}
    driven = _driven(playback, EGO)
    track = playback.tracks[EGO]
    reached = np.nonzero(driven >= stop_line)[0]
    if len(reached):
        i = int(reached[0])
        x, y, h = track["x"][i], track["y"][i], track["h"][i]
    else:  # not reached: the line lies ahead of where the ego ended, along its heading
        ahead, h = stop_line - float(driven[-1]), track["h"][-1]
        x, y = track["x"][-1] + ahead * math.cos(h), track["y"][-1] + ahead * math.sin(h)
    return {"distance": np.round(driven, 3).tolist(), "line_m": stop_line,
            "at": [round(x, 3), round(y, 3), round(h, 5)]}


def _recorded(folder: Path, params: Params) -> dict:
    """A mined record's series (params' ``recorded_series``, else the folder's
    ``recorded.json``) on the scenario's clock: its event starts with the manoeuvre."""
    recorded = params.get("recorded_series")
    if not isinstance(recorded, dict):
        recorded = read_json_object(folder / RECORDED_NAME)
    if not isinstance(recorded.get("t"), list):
        return {}
    shift = finite(params.get("maneuver_start_s")) or 0.0
    return {**recorded, "t": [None if t is None else t + shift for t in recorded["t"]]}


def _gap_chart(playback: Playback, params: Params, recorded: dict, map_path: Path | None,
               verdict: ReplayVerdict | None) -> dict:
    """Every other vehicle's gap to the ego along its lane (highway; the judge's measure),
    with the gaps the judge expected (its verdict)."""
    others = [e for e in playback.entities if e != EGO]
    if not others or EGO not in playback.tracks:
        return {}
    times = np.round(np.arange(0.0, playback.duration_s + 1e-9, GAP_STEP_S), 3).tolist()
    series = {name: [None if gap is None else round(gap, 3)
                     for gap in gap_series(playback, name, times, map_path)] for name in others}
    tolerances = verdict["tolerances"] if verdict else None
    kind = params.get("npc_vehicle_type")
    # the record's gap is between bumpers; the chart's, like the judge's, between reference points
    recorded_gap = [None if g is None else round(reference_gap_m(g, kind), 3)
                    for g in recorded.get("npc_gap_m") or []] or None
    return {"times": times, "series": series,
            "marks": _marks(verdict["gap_marks"] if verdict else []),
            "tol": tolerances["gap_m"] if tolerances else None,
            "series_tol": tolerances["series_gap_m"] if tolerances else None,
            "recorded": recorded_gap,
            "recorded_t": recorded.get("t")}


# --- the verdict -----------------------------------------------------------------------------

def _findings(verdict: ReplayVerdict | None, status: dict) -> list[dict]:
    """The judge's REPLAY_* findings, each with its time where it has one (the verdict's);
    a folder played before the judge wrote verdicts shows its status' findings, untimed."""
    if verdict is not None:
        return [{"code": f["code"], "message": f["message"], "t": f["t"]}
                for f in verdict["findings"]]
    return [{"code": code, "message": message, "t": None}
            for code, message in _status_findings(status)]


def _status_findings(status: dict) -> list[tuple[str, str]]:
    errors = (status.get("validation") or {}).get("errors") or []
    return [(e.get("code", ""), e.get("message", "")) for e in errors
            if isinstance(e, dict) and str(e.get("code", "")).startswith("REPLAY")]


def _series_errors(raw: dict, status: dict) -> dict:
    """The judge's per-quantity errors against the record's series (max, RMS), where the
    replay or the status has them (an additive key of the replay judge)."""
    for source in (raw, status.get("replay") or {}):
        for key in ("series_errors", "series"):
            value = source.get(key)
            if isinstance(value, dict) and value:
                return value
    return {}

"""The in-situ scene: a mined event played on its recorded road with every recorded vehicle
(``<scenario folder>/in_situ/``, written by ``mining.in_situ``), as the page animates it.

Like a Town scenario's scene (``viewer.scene``) it is drawn from the folder's ``replay.json``
(what esmini played), with the lanes of the folder's own ``road.xodr``; in addition each
vehicle has its ``span`` (first and last recorded time, from the scenario's trajectories:
``judge.in_situ_doc``) so the page shows a car only while it is recorded, not while it waits
parked off the road, and the judge's numbers (``judge.json``: the share of recorded samples
played within 0.1 m, the worst sample, per vehicle) come along as ``in_situ``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from scenweave.judge.in_situ_doc import (
    JUDGE_NAMES,
    InSituDoc,
    InSituDocError,
    is_in_situ,
    judge_numbers,
    read_in_situ,
)
from scenweave.player import Playback
from scenweave.schemas.scenario_folder import (
    HERO_REFERENCE_NAME,
    IN_SITU_CHOICE_NAME,
    IN_SITU_DIR,
    REPLAY_NAME,
    ROAD_NAME,
    XOSC_NAME,
    read_json_object,
)
from scenweave.viewer.scene import EGO, MAP_MARGIN_M, _actors, _lane_polylines

#: the files of an in-situ folder the page lists and serves
IN_SITU_FILES = (XOSC_NAME, ROAD_NAME, IN_SITU_CHOICE_NAME, REPLAY_NAME, *JUDGE_NAMES,
                 HERO_REFERENCE_NAME)

__all__ = ["IN_SITU_FILES", "in_situ_of", "in_situ_row", "in_situ_scene", "is_in_situ"]


def in_situ_of(folder: Path) -> Path | None:
    """The in-situ folder of a scenario folder, if it has one."""
    candidate = Path(folder) / IN_SITU_DIR
    return candidate if is_in_situ(candidate) else None


def in_situ_row(folder: Path) -> dict[str, Any]:
    """What the run list says of a scenario's in-situ folder: vehicles, verdict, the share
    within 0.1 m and the worst sample."""
    choice = read_json_object(folder / IN_SITU_CHOICE_NAME)
    judged = judge_numbers(folder)
    position = (judged.get("overall") or {}).get("position") or {}
    return {"vehicles": choice.get("vehicles") or len(choice.get("tracks") or {}) or None,
            "played": (folder / REPLAY_NAME).is_file(),
            "passed": judged.get("passed") if judged else None,
            "share": position.get("share"), "worst_m": position.get("worst_m")}


def in_situ_scene(folder: Path) -> dict[str, Any]:
    """The in-situ scenario in ``folder`` as the page animates it (the keys of
    ``viewer.scene.scene``, plus ``in_situ``: the choice and the judge's numbers)."""
    choice = read_json_object(folder / IN_SITU_CHOICE_NAME)
    judged = judge_numbers(folder)
    out: dict[str, Any] = {"scenario_id": _title(folder, choice), "maneuver_class": "in situ",
                           "domain": Path(str(choice.get("file") or "")).name or None,
                           "played": False,
                           "in_situ": {"choice": choice, "judge": judged,
                                       "passed": judged.get("passed") if judged else None}}
    try:
        doc = read_in_situ(folder)
    except InSituDocError as err:
        out["problem"] = str(err)
        return out
    if not (folder / REPLAY_NAME).is_file():
        out["problem"] = "not played: no replay.json in the in-situ folder"
        return out
    playback = Playback.from_dict(read_json_object(folder / REPLAY_NAME))
    if playback.engine_error or not playback.times:
        out.update(problem=playback.engine_error or "esmini recorded no step",
                   log=playback.log[-10:])
        return out
    actors = _actors(playback)
    spans = {v.name: list(v.span) for v in doc.vehicles}
    for name, actor in actors.items():
        actor["span"] = spans.get(name)
    out.update(played=True, duration_s=playback.duration_s, times=playback.times,
               actors=actors, lights=_lights(folder / ROAD_NAME, doc, playback.duration_s),
               collisions=[list(c) for c in playback.collisions],
               lanes=_lanes_around(folder / ROAD_NAME, playback, spans),
               map=ROAD_NAME, charts=_charts(playback), findings=_findings(judged),
               series_errors={})
    return out


def _title(folder: Path, choice: dict[str, Any]) -> str:
    owner = folder.parent.name if folder.name == IN_SITU_DIR else folder.name
    ego = choice.get("ego_track")
    return f"{owner} in situ" + (f" (ego track {ego})" if ego else "")


def _on_road(playback: Playback, spans: dict[str, list[float]]) -> tuple[list[float], ...]:
    """Every played position while its vehicle is recorded (not parked)."""
    times = np.asarray(playback.times)
    xs: list[float] = []
    ys: list[float] = []
    for name, track in playback.tracks.items():
        first, last = spans.get(name) or (times[0], times[-1])
        keep = (times >= first - 1e-6) & (times <= last + 1e-6)
        xs += np.asarray(track["x"])[keep].tolist()
        ys += np.asarray(track["y"])[keep].tolist()
    return xs, ys


def _lanes_around(road: Path, playback: Playback, spans: dict[str, list[float]]) -> list[dict]:
    """The recorded road's lane borders within ``MAP_MARGIN_M`` of where the cars drove."""
    xs, ys = _on_road(playback, spans)
    if not road.is_file() or not xs:
        return []
    box = (min(xs) - MAP_MARGIN_M, max(xs) + MAP_MARGIN_M,
           min(ys) - MAP_MARGIN_M, max(ys) + MAP_MARGIN_M)
    return [{"junction": junction, "points": points}
            for bounds, junction, points in _lane_polylines(str(road.resolve()))
            if bounds[0] <= box[1] and bounds[1] >= box[0] and bounds[2] <= box[3]
            and bounds[3] >= box[2]]


def _lights(road: Path, doc: InSituDoc, duration_s: float) -> list[dict]:
    """Each recorded light's signals where the map places them, with their recorded colours
    (the scenario's TrafficSignalController phases)."""
    if not doc.signals or not road.is_file():
        return []
    from scenweave import roads

    try:
        placed = roads.traffic_lights_carla(road)
    except roads.OpenDriveError:
        return []
    return [{"x": placed[signal][0], "y": -placed[signal][1], "signal": signal,
             "spans": [[a, min(b, duration_s), state] for a, b, state in spans]}
            for signal, spans in sorted(doc.signals.items()) if signal in placed]


def _charts(playback: Playback) -> dict[str, Any]:
    """The ego's speed and lane (the other vehicles are judged against their record; their
    numbers are in the table beside the scene)."""
    shown = [n for n in (EGO,) if n in playback.tracks]
    return {"speed": {"series": {n: playback.tracks[n]["speed"] for n in shown}, "marks": [],
                      "tol": 0.1, "recorded": {}},
            "gap": {}, "stop_line": {}, "light": [],
            "lateral": {"offset": {n: playback.tracks[n]["lane_offset"] for n in shown},
                        "lane": {n: playback.tracks[n]["lane"] for n in shown}}}


def _findings(judged: dict[str, Any]) -> list[dict]:
    """The judge's IN_SITU_* findings, each at the time the judge wrote beside it."""
    found = []
    for finding in judged.get("findings") or []:
        if not isinstance(finding, dict):
            continue
        when = finding.get("t")
        found.append({"code": finding.get("code", ""), "message": str(finding.get("message", "")),
                      "severity": finding.get("severity"),
                      "t": float(when) if isinstance(when, (int, float)) else None})
    return found

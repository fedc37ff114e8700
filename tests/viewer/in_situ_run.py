"""A small in-situ scene for the viewer's and the exports' tests: the hand-written lane network
(``tests/roads/recorded_network.py``, as CommonRoad XML) converted by the real converter, four
recorded vehicles on it (the ego, one appearing late, one leaving early, a truck), its light,
played in the real esmini and judged (``mining.in_situ.write_in_situ``), inside a run folder
``runs/insitu/FLF_mined_fixture/in_situ/`` as ``scenweave run`` of a mined record leaves it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from scenweave.mining.in_situ import road_of, write_in_situ
from scenweave.mining.tracks import LightPhase, Recording, Track, TrafficLight
from tests.mining.road_fixture import write_road_fixture

RUN_ID = "insitu"
SCENARIO = "FLF_mined_fixture"
#: each fixture vehicle: track id, first and last time (s), first x (m), speed (m/s), y (m),
#: kind, length (m). Lanes run along +x, 3.5 m wide, centres at y = 3.5, 0, -3.5
VEHICLES = (("1", 0.0, 9.0, 5.0, 10.0, 0.0, "car", 4.5),       # the ego, lanelets 2, 5, 7
            ("2", 2.0, 8.0, 20.0, 8.0, 3.5, "car", 4.6),       # appears late, lanelets 1, 4, 5
            ("3", 0.0, 5.0, 30.0, 6.0, -3.5, "car", 4.2),      # leaves early, lanelets 3, 6
            ("4", 0.0, 9.0, 40.0, 9.0, 0.0, "truck", 9.0))     # ahead of the ego
#: the late vehicle changes from y = 3.5 to y = 0 over these seconds (a smooth S)
LANE_CHANGE_S = (5.0, 7.5)
RECORD = {"scenario_id": SCENARIO, "provenance": {"tracks": {"ego": "1"}, "start_s": 3.0,
                                                  "end_s": 6.0}}


def track(track_id: str, start: float, end: float, x0: float, speed: float, y: float,
          kind: str, length: float) -> Track:
    t = np.round(np.arange(start, end + 1e-9, 0.1), 3)
    x = x0 + speed * (t - start)
    n = len(t)
    ys, heading = np.full(n, y), np.zeros(n)
    if track_id == "2":  # into the ego's lane: y follows a cosine step, heading its slope
        first, last = LANE_CHANGE_S
        phase = np.clip((t - first) / (last - first), 0.0, 1.0)
        ys = y - y * (1 - np.cos(np.pi * phase)) / 2
        slope = np.where((t > first) & (t < last),
                         -y * np.pi / 2 * np.sin(np.pi * phase) / (last - first) / speed, 0.0)
        heading = np.arctan(slope)
    return Track(track_id, length, 1.9, kind, t, x, ys, heading, np.full(n, speed), x.copy(),
                 np.array(["2"] * n))


def recording(source: Path) -> Recording:
    light = TrafficLight("500", ("9",), 200.0, (LightPhase(0.0, 4.0, "green"),
                                                 LightPhase(4.0, 5.0, "yellow"),
                                                 LightPhase(5.0, 30.0, "red")))
    return Recording(str(source), 0.1, [track(*v) for v in VEHICLES], lights=[light],
                     reader="commonroad")


def make_in_situ_run(root: Path) -> Path:
    """``root/runs/insitu`` with one scenario folder holding its played ``in_situ/``; the
    scenario folder."""
    source = write_road_fixture(root / "ZAM_Road-1_1_T-1.xml")
    road = road_of(source, root / "road-cache")
    run = root / "runs" / RUN_ID
    folder = run / SCENARIO
    folder.mkdir(parents=True)
    (run / "run.json").write_text(json.dumps({"run_id": RUN_ID, "mode": "no-llm",
                                              "input": str(root)}))
    (folder / "status.json").write_text(json.dumps({"scenario_id": SCENARIO,
                                                    "maneuver_class": "FLF", "status": "ok"}))
    result = write_in_situ(recording(source), RECORD, folder, road)
    assert result.verdict is not None and result.verdict.passed, result.verdict
    return folder

"""Stops at red (U4_1) and passes on green (U4_3) found at a recording's traffic lights, as
urban records ingest's own canonicaliser made from an ADScene object."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.ingest import check_record, extract_params, load_records
from scenweave.mining import LightPhase, Recording, TrafficLight
from scenweave.mining.detect import detect
from scenweave.mining.mine import mine_recordings
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import DT, car, steady

LIGHT = TrafficLight(id="L1", lanes=("1",), stop_line_s=100.0,
                     phases=(LightPhase(0.0, 20.0, "red"), LightPhase(20.0, 41.0, "green")))


def stopping(v0: float, brake_from_s: float, decel: float):
    return lambda t: np.clip(v0 - decel * np.clip(t - brake_from_s, 0, None), 0.0, None)


def junction() -> Recording:
    tracks = [car("stopper", 40, 10, stopping(12, 4, 2), 1),
              car("passer", 40, -240, steady(12), 1),
              car("elsewhere", 40, 10, stopping(12, 4, 2), 2)]
    return Recording(source="junction-1.xml", dt=DT, tracks=tracks, lights=[LIGHT],
                     reader="synthetic")


def test_a_car_stopping_at_its_red_light_and_one_passing_on_green():
    events = detect(junction(), load_thresholds())
    found = {(e.code, e.ego) for e in events if e.code.startswith("U")}
    assert found == {("U4_1", "stopper"), ("U4_3", "passer")}


def test_light_events_become_urban_records_of_their_class(tmp_path):
    report = mine_recordings([junction()], tmp_path, load_thresholds(), classes=("U4_1", "U4_3"))
    assert report.written == {"U4_1": 1, "U4_3": 1}, report.skipped
    records = {r["maneuver_class"]: r for r in load_records(tmp_path)}
    stop = records["U4_1"]
    check_record(stop)
    params = extract_params(stop)
    assert params["tfl_state"] == "red"
    assert abs(params["ego_speed_ms"] - 12) < 0.2
    assert abs(params["tfl_ds_m"] - 90.0) < 0.5  # the stop line, 90 m from the window start
    assert params["ego_end_speed_ms"] < 0.5
    assert stop["provenance"]["tracks"] == {"ego": "stopper"}
    assert extract_params(records["U4_3"])["tfl_state"] == "green"


def test_a_mined_stop_at_red_plays_back(tmp_path, esmini):
    mine_recordings([junction()], tmp_path / "records", load_thresholds(), classes=("U4_1",))
    ran = CliRunner().invoke(cli, ["run", str(tmp_path / "records"), "--no-llm", "--out",
                                   str(tmp_path / "runs"), "--run-id", "light"])
    assert ran.exit_code == 0, ran.output
    summary = json.loads((tmp_path / "runs" / "light" / "summary.json").read_text())
    assert [o["status"] for o in summary["scenarios"]] == ["ok"], summary

"""Mining end to end: a recording -> canonical records (checked, playable or skipped with a
reason) -> ``scenweave run`` plays them back as recorded; the report draws them."""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.ingest import extract_params, load_records
from scenweave.mining.mine import mine_recordings
from scenweave.mining.thresholds import load_thresholds
from scenweave.presentation.mining_report import write_mining_report
from scenweave.schemas.scenario_folder import MINING_REPORT_NAME
from tests.mining.synthetic import braking, car, recording, steady, switch


def road():
    return recording(car("lead", 14, 70, braking(24, 4, 4, 12), 2),
                     car("ego", 14, 35, braking(24, 4.3, 4, 12), 2),  # slows with it
                     car("cutter", 14, 10, steady(26), switch(3, 2, 7)),
                     car("far", 14, 300, steady(30), 1), source="road-1.xml")


def test_mined_records_are_canonical_and_say_where_they_come_from(tmp_path):
    report = mine_recordings([road()], tmp_path, load_thresholds())
    records = list(load_records(tmp_path))
    assert len(records) == sum(report.written.values()) > 0
    brake = next(r for r in records if r["maneuver_class"] == "BRAKE")
    assert brake["provenance"]["tracks"] == {"ego": "ego", "npc": "lead"}
    assert brake["provenance"]["file"] == "road-1.xml"
    assert brake["scenario_id"].startswith("BRAKE_mined_road-1_row")
    assert len(brake["series"]["t"]) == len(brake["series"]["npc_speed_ms"]) > 10
    params = extract_params(brake)
    assert params["npc_speed_ms"] == brake["params"]["lead_vel_kmh"] / 3.6
    saved = json.loads((tmp_path / MINING_REPORT_NAME).read_text())
    assert saved["files"]["road-1.xml"]["events_by_class"]["BRAKE"] == 1
    assert saved["values"]["BRAKE"]["npc_distance_m"]


def test_events_no_scenario_can_play_are_skipped_with_the_reason(tmp_path):
    squeezed = recording(car("lead", 10, 35, steady(15), 2), car("ego", 10, 30, steady(25), 2))
    # a follow now ends where the bumpers meet (issue 36); thresholds that let the detector
    # take the overlap show what mining does with an event no scenario can play
    limits = load_thresholds()
    limits["follow"] = {**limits["follow"], "min_gap_m": -1e9}
    report = mine_recordings([squeezed], tmp_path, limits)
    assert report.skipped, "a car running into its lead is no record"
    assert all(s["reason"] and s["scenario_id"] for s in report.skipped)


def test_the_report_draws_a_histogram_per_class(tmp_path):
    mine_recordings([road()], tmp_path, load_thresholds())
    html = write_mining_report(tmp_path / MINING_REPORT_NAME).read_text()
    assert "Mining report" in html and "road-1.xml" in html
    assert html.count("<svg") >= 4 and "histogram of npc_distance_m" in html


def test_scenweave_run_plays_mined_records_back(tmp_path, esmini):
    mine_recordings([road()], tmp_path / "records", load_thresholds(), classes=("BRAKE",))
    ran = CliRunner().invoke(cli, ["run", str(tmp_path / "records"), "--no-llm", "--out",
                                   str(tmp_path / "runs"), "--run-id", "mined"])
    assert ran.exit_code == 0, ran.output
    summary = json.loads((tmp_path / "runs" / "mined" / "summary.json").read_text())
    assert [o["status"] for o in summary["scenarios"]] == ["ok"], summary["scenarios"]


def test_a_mined_brake_survives_the_round_trip(tmp_path, esmini):
    from scenweave.mining.roundtrip import round_trip
    from scenweave.player import Playback

    limits = load_thresholds()
    mine_recordings([road()], tmp_path / "records", limits, classes=("BRAKE",))
    (record,) = load_records(tmp_path / "records")
    CliRunner().invoke(cli, ["run", str(tmp_path / "records"), "--no-llm", "--out",
                             str(tmp_path / "runs"), "--run-id", "rt"])
    playback = Playback.read(tmp_path / "runs" / "rt" / record["scenario_id"] / "replay.json")
    trip = round_trip(record, playback, limits)
    assert trip.found, "the replayed scenario shows the lead braking in front of the ego"
    assert trip.holds, trip.misses


def test_the_replay_figure_of_a_mined_record_draws_what_was_recorded(tmp_path, esmini):
    mine_recordings([road()], tmp_path / "records", load_thresholds(), classes=("BRAKE",))
    CliRunner().invoke(cli, ["run", str(tmp_path / "records"), "--no-llm", "--out",
                             str(tmp_path / "runs"), "--run-id", "fig"])
    (record,) = load_records(tmp_path / "records")
    folder = tmp_path / "runs" / "fig" / record["scenario_id"]
    recorded = json.loads((folder / "recorded.json").read_text())
    assert recorded == record["series"]
    from scenweave.presentation.replay_facts import ReplayFacts

    times, speeds = ReplayFacts.read(folder).recorded_curve("npc_speed_ms")
    assert 2.0 <= times[0] < 2.1  # the event starts when the scenario's manoeuvre does
    assert speeds[0] == record["series"]["npc_speed_ms"][0]
    from lxml import etree

    figure = etree.parse(str(folder / "replay.svg")).getroot()
    dashed = [p for p in figure.iter("{http://www.w3.org/2000/svg}path")
              if p.get("stroke-dasharray") and len(p.get("d", "")) > 100]
    assert len(dashed) >= 2, "the recorded speed and gap series, dashed beside the replay's"

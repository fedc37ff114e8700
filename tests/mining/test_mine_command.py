"""``scenweave mine`` as a user runs it: every fixture format in, records and a report out."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.mining.mine import mine_recordings
from scenweave.mining.readers import read_recordings
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import braking, car, recording, steady


def test_mining_the_fixture_folder_writes_records_and_a_report(data, tmp_path):
    result = CliRunner().invoke(cli, ["mine", str(data), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "mine:" in result.output and "open" in result.output
    report = json.loads((tmp_path / "out" / "mining_report.json").read_text())
    readers = {f["reader"] for f in report["files"].values()}
    assert {"commonroad", "ngsim-csv", "highd"} <= readers
    assert report["records_written"] == sum(report["records_by_class"].values()) > 0
    assert (tmp_path / "out" / "mining_report.html").stat().st_size > 1000


def test_json_output_and_a_class_filter(data, tmp_path):
    result = CliRunner().invoke(cli, ["mine", str(data), "--out", str(tmp_path / "out"),
                                      "--classes", "LCF,LCB", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert set(report["records_by_class"]) <= {"LCF", "LCB"}


def test_a_bad_thresholds_file_is_one_line(data, tmp_path):
    bad = tmp_path / "t.json"
    bad.write_text("{}")
    result = CliRunner().invoke(cli, ["mine", str(data), "--out", str(tmp_path / "out"),
                                      "--thresholds", str(bad)])
    assert result.exit_code != 0
    assert "section 'smoothing' is missing" in result.output


def test_a_crawling_car_is_a_record_unless_the_thresholds_skip_stop_and_go(tmp_path):
    """A start from (near) standstill plays as a speed profile (issue 22): kept by default;
    ``records.min_start_speed_ms`` raised skips it, naming the car and the setting."""
    queue = recording(car("lead", 10, 20, braking(6, 2, 3, 0), 2),
                      car("ego", 10, 5, steady(0.5), 2))
    kept = mine_recordings([queue], tmp_path / "kept", load_thresholds())
    assert sum(kept.written.values()) >= 1 and not kept.skipped
    strict = load_thresholds()
    strict["records"]["min_start_speed_ms"] = 2.0
    skipped = mine_recordings([queue], tmp_path / "strict", strict)
    moving = [s for s in skipped.skipped if "records.min_start_speed_ms = 2" in s["reason"]]
    assert moving and moving[0]["field"] == "series.ego_speed_ms"


@pytest.mark.slow
def test_the_us101_snippets_give_following_and_braking_records(ngsim_snippets, tmp_path):
    # the rate (vehicle-hours per second) is benchmarks/mine.py's to measure, not a test's
    report = mine_recordings(read_recordings(ngsim_snippets / "us101"), tmp_path,
                             load_thresholds())
    assert report.vehicle_hours > 0 and report.seconds > 0
    assert report.written["FLF"] > 10 and report.written["BR_BK"] > 0

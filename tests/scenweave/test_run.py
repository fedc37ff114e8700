"""``scenweave run --no-llm`` end to end on sample data, with the real stages."""

from __future__ import annotations

import json
import shutil

import pytest
from click.testing import CliRunner

from scenweave import maneuvers
from scenweave.cli import cli
from scenweave.commands.agent_options import replay_settings_for
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.player import ReplaySettings
from scenweave.runner import default_matcher, run_batch

SCENARIO_FILES = {"scenario.xosc", "scenario.py", "params.json", "status.json", "trace.jsonl"}


@pytest.fixture(scope="module")
def matcher():
    return default_matcher()


@pytest.fixture(scope="module")
def first_run(sample_raw, tmp_path_factory, matcher):
    """The sample data through every stage, the replay in esmini included."""
    out = tmp_path_factory.mktemp("runs")
    result = run_batch(sample_raw, out, InputSelection(),
                       PipelineSettings(no_llm=True, replay=replay_settings_for(None)),
                       run_id="r1", matcher=matcher)
    return result, out


def test_every_sample_scenario_replays_as_recorded(first_run, esmini):
    result, out = first_run
    replay = result.summary["replay"]
    assert replay["played"] == result.summary["total"] == replay["passed"], replay["codes"]
    assert all((out / "r1" / o["scenario_id"] / "replay.json").is_file()
               for o in result.summary["scenarios"])
    assert f"replay: {replay['passed']}/{replay['played']} played as recorded" in result.line()


def test_jobs_make_the_same_scenarios_in_several_processes(first_run, sample_raw, tmp_path,
                                                           matcher, esmini):
    result, out = first_run
    parallel = run_batch(sample_raw, tmp_path, InputSelection(),
                         PipelineSettings(no_llm=True, replay=ReplaySettings()),
                         run_id="r2", matcher=matcher, jobs=2)
    statuses = {o["scenario_id"]: (o["status"], o["spawn_id"], o["replay"]["passed"])
                for o in parallel.summary["scenarios"]}
    assert statuses == {o["scenario_id"]: (o["status"], o["spawn_id"], o["replay"]["passed"])
                        for o in result.summary["scenarios"]}
    for scenario_id in statuses:
        assert ((tmp_path / "r2" / scenario_id / "scenario.xosc").read_bytes()
                == (out / "r1" / scenario_id / "scenario.xosc").read_bytes()), scenario_id


def test_every_sample_record_becomes_a_valid_scenario(first_run):
    result, _ = first_run
    summary = result.summary
    highway, urban = maneuvers.codes("highway"), maneuvers.codes("urban")
    assert summary["total"] == len(highway) * 3 + len(urban) * 2  # tests/conftest.py sample_raw
    failed = [(o["scenario_id"], o["error"]) for o in summary["scenarios"] if o["status"] != "ok"]
    assert failed == []
    assert summary["counts"]["ok"] == summary["total"]
    assert set(summary["by_class"]) == {*highway, *urban}


def test_each_scenario_folder_is_complete_and_nothing_is_left_half_written(first_run):
    result, _ = first_run
    root = result.folder.root
    folders = [p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")]
    assert len(folders) == result.summary["total"]
    for folder in folders:
        assert {p.name for p in folder.iterdir()} >= SCENARIO_FILES, folder.name
        params = json.loads((folder / "params.json").read_text())
        assert params["spawn_id"] is not None and params["ego_x"] is not None
    assert not (root / ".staging").exists()  # no staging leftovers, not even its folder
    summary = json.loads((root / "summary.json").read_text())
    assert summary["total"] == result.summary["total"]


def test_spawns_go_round_robin_within_a_class(first_run):
    result, _ = first_run
    spawns = [o["spawn_id"] for o in result.summary["scenarios"] if o["maneuver_class"] == "BRAKE"]
    assert len(set(spawns)) == 3


def test_rerun_resumes_and_redoes_only_what_is_missing(first_run, sample_raw, matcher):
    result, out = first_run
    root = result.folder.root
    victim = next(p for p in sorted(root.iterdir()) if p.is_dir() and p.name.startswith("LCF"))
    kept = next(p for p in sorted(root.iterdir()) if p.is_dir() and p.name.startswith("FLF"))
    kept_mtime = (kept / "scenario.xosc").stat().st_mtime_ns
    shutil.rmtree(victim)
    (root / ".staging" / "half_written").mkdir(parents=True)  # a crash's leftover
    again = run_batch(sample_raw, out, InputSelection(), PipelineSettings(no_llm=True),
                      run_id="r1", matcher=matcher)
    assert again.skipped == result.summary["total"] - 1
    assert not (root / ".staging").exists()
    assert (victim / "scenario.xosc").exists()
    assert (kept / "scenario.xosc").stat().st_mtime_ns == kept_mtime
    assert again.summary["counts"]["ok"] == result.summary["total"]


def test_a_bad_canonical_record_fails_alone(sample_raw, tmp_path, matcher):
    records = tmp_path / "records"
    CliRunner().invoke(cli, ["ingest", str(sample_raw), "--out", str(records)])
    path = records / "highway" / "BRAKE.json"
    data = json.loads(path.read_text())
    del data[1]["params"]["lead_vel_kmh"]
    path.write_text(json.dumps(data))
    result = run_batch(records, tmp_path / "runs", InputSelection(classes=("BRAKE", "LCF")),
                       PipelineSettings(no_llm=True), run_id="bad", matcher=matcher)
    [issue] = result.input_issues
    assert issue["field"] == "params.lead_vel_kmh" and "row000001" in issue["message"]
    assert result.summary["counts"]["ok"] == 5


def test_cli_prints_one_line_pointing_at_the_run_folder(sample_raw, tmp_path):
    outcome = CliRunner().invoke(cli, ["run", str(sample_raw), "--no-llm", "--out",
                                       str(tmp_path), "--run-id", "cli", "--classes", "U4_1",
                                       "--per-class", "1"])
    assert outcome.exit_code == 0, outcome.output
    line = outcome.output.strip().splitlines()[-1]
    assert line.startswith("run cli: 1 scenarios: 1 ok") and str(tmp_path / "cli") in line

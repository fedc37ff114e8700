"""The command line tells the truth (issue 25): what ingest admits run makes, warnings come once
per file and field, exit codes say what happened, the console counts problems, output is
replaced or left whole and readable, one vocabulary, and a default that works."""

from __future__ import annotations

import json
import stat
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from scenweave import cli as cli_module
from scenweave.cli import cli
from scenweave.commands.agent_options import LLM_CHOICES, LlmChoice, auto_llm
from scenweave.commands.demo import attempts_line
from scenweave.commands.logs import reply_preview
from scenweave.ingest import ingest_directory
from tests.ingest.builders import scene, write_npy, write_scene

U4_1_SPEEDS = [36, 30, 20, 10, 0, 0]
GOOD_LCF = [["126", "133.2", "4", "No", "Left"]]
#: a lead braking at 36 km/h in 0.5 s (20 m/s^2): no car can, no scenario can show it
IMPOSSIBLE_BRAKE = ["108", "90", "0.5", "-36", "30.5", "0.4", "Yes", "Car"]


def _stop_at_red(frames: int = 6) -> dict:
    times = [float(i) for i in range(frames)]
    speeds = (U4_1_SPEEDS + [0] * frames)[:frames]
    odometer = [0.0]
    for v0, v1 in zip(speeds, speeds[1:], strict=False):
        odometer.append(odometer[-1] + (v0 + v1) / 2 / 3.6)
    return scene("U4_1", speeds, times, odometer, light=(odometer[-1] + 2.0, 172))


def _tolerant(data: dict) -> dict:
    """The readings a tolerant reader takes: optional way-point elements absent, a label as
    text, a code as text, numbers as strings."""
    data["environment"]["infrastructure"]["way_points"][0]["infrastructure_elements"] = [
        {"type": "RoadType", "value": "Urban Road"}]
    for frame in data["key_times"]:
        frame["temporal_climatic"]["day_period"] = "Day"
        frame["ego_vehicle"]["ego_speed"] = str(frame["ego_vehicle"]["ego_speed"])
    light = data["environment"]["infrastructure"]["way_points"][1]["infrastructure_elements"][0]
    light["value"] = "172"
    return data


def invoke(*args: str, **kwargs):
    return CliRunner().invoke(cli, [str(a) for a in args], **kwargs)


# -- 1. one notion of valid -------------------------------------------------------------------

def test_a_record_ingest_admits_in_a_tolerant_reading_is_a_scenario_run_makes(tmp_path):
    write_scene(tmp_path / "raw", _tolerant(_stop_at_red()), "1.0.json")
    ingested = invoke("ingest", tmp_path / "raw", "--out", tmp_path / "rec", "--json")
    assert ingested.exit_code == 0, ingested.output
    report = json.loads(ingested.output)
    assert report["records_written"] == 1 and report["errors"] == 0
    assert {i["severity"] for i in report["issues"]} == {"warning"}
    ran = invoke("run", tmp_path / "rec", "--out", tmp_path / "runs", "--no-llm", "--no-replay",
                 "--json")
    assert ran.exit_code == 0, ran.output
    summary = json.loads(ran.stdout)
    assert summary["counts"]["ok"] == 1 and summary["input_issues"] == []
    [outcome] = summary["scenarios"]
    params = json.loads((tmp_path / "runs" / summary["run_id"] / outcome["scenario_id"]
                         / "params.json").read_text())
    assert params["lane_count"] is None and params["tfl_state"] == "red"


def test_the_raw_folder_run_reads_gives_the_same_scenarios_as_ingest_then_run(tmp_path):
    write_scene(tmp_path / "raw", _tolerant(_stop_at_red()), "1.0.json")
    write_npy(tmp_path / "raw", "BRAKE", [IMPOSSIBLE_BRAKE])
    report = ingest_directory(tmp_path / "raw", tmp_path / "rec")
    raw = invoke("run", tmp_path / "raw", "--out", tmp_path / "a", "--no-llm", "--no-replay",
                 "--json")
    records = invoke("run", tmp_path / "rec", "--out", tmp_path / "b", "--no-llm",
                     "--no-replay", "--json")
    made = [sorted(o["scenario_id"] for o in json.loads(r.stdout)["scenarios"])
            for r in (raw, records)]
    assert made[0] == made[1] and len(made[0]) == report.records_written == 1
    assert [i.field for i in report.errors] == ["delta_vel_kmh"]


# -- 2. warnings once per file and field -------------------------------------------------------

def test_a_label_read_in_every_frame_is_one_warning_with_its_count(tmp_path):
    write_scene(tmp_path / "raw", _tolerant(_stop_at_red(frames=400)), "1.0.json")
    report = ingest_directory(tmp_path / "raw", tmp_path / "rec")
    day = [i for i in report.issues if (i.field or "").endswith("day_period")]
    assert len(day) == 1
    assert day[0].count == 400 and day[0].field == "key_times[*].temporal_climatic.day_period"
    assert day[0].message == "'Day' read as code 1 (Day) in 400 frames"
    assert len(report.issues) == 4  # day period, ego speed as text, road type label, light code
    assert (tmp_path / "rec" / "ingest_report.json").stat().st_size < 4_000


# -- 3. exit codes ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def mixed(tmp_path_factory) -> Path:
    """One good lane change and one braking no car can do."""
    raw = tmp_path_factory.mktemp("mixed")
    write_npy(raw, "LCF", GOOD_LCF)
    write_npy(raw, "BRAKE", [IMPOSSIBLE_BRAKE] * 5)
    return raw


def test_run_exits_0_when_all_is_delivered_and_1_when_a_record_is_refused(mixed, tmp_path):
    good = invoke("run", mixed, "--classes", "LCF", "--out", tmp_path, "--no-llm",
                  "--no-replay")
    assert good.exit_code == 0, good.output
    refused = invoke("run", mixed, "--out", tmp_path, "--no-llm", "--no-replay")
    assert refused.exit_code == 1, refused.output


def test_run_exits_1_when_nothing_was_made(mixed, tmp_path):
    result = invoke("run", mixed, "--classes", "U4_1", "--out", tmp_path, "--no-llm",
                    "--no-replay")
    assert result.exit_code == 1 and "0 scenarios" in result.stdout


@pytest.mark.parametrize("args, words", [
    (["--classes", "BRAKEE"], "unknown class BRAKEE"),
    (["--map", "Town03"], "unknown map 'Town03'"),
    (["--jobs", "0"], "--jobs"),
])
def test_a_usage_error_exits_2_before_anything_is_written(mixed, tmp_path, args, words):
    result = invoke("run", mixed, "--out", tmp_path / "runs", "--no-llm", *args)
    assert result.exit_code == 2 and words in result.output
    assert not (tmp_path / "runs").exists()


def test_a_missing_path_is_a_usage_error(tmp_path):
    for command in (["run"], ["ingest", "--out", str(tmp_path)], ["mine", "--out", str(tmp_path)],
                    ["replay"], ["validate"]):
        result = invoke(*command, tmp_path / "nowhere")
        assert result.exit_code == 2, (command, result.output)


def test_ingest_exits_1_when_a_record_is_refused(mixed, tmp_path):
    assert invoke("ingest", mixed, "--out", tmp_path).exit_code == 1
    write_npy(tmp_path / "good", "LCF", GOOD_LCF)
    assert invoke("ingest", tmp_path / "good", "--out", tmp_path / "o").exit_code == 0


def test_mine_exits_1_when_nothing_could_be_read(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "notes.txt").write_text("not trajectories")
    result = invoke("mine", tmp_path / "data", "--out", tmp_path / "out")
    assert result.exit_code == 1 and "mine: 0 records" in result.stdout


def test_an_interrupted_run_exits_130_and_says_how_to_resume(mixed, tmp_path, monkeypatch,
                                                             capsys):
    from scenweave import runner

    real = runner.make_scenario if hasattr(runner, "make_scenario") else None
    calls = []

    def interrupted_on_the_second(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return (real or runner.process_scenario)(*args, **kwargs)

    monkeypatch.setattr(runner, "make_scenario" if real else "process_scenario",
                        interrupted_on_the_second)
    write_npy(tmp_path / "raw", "LCF", GOOD_LCF * 3)
    with pytest.raises(SystemExit) as exited:
        cli_module.main(["run", str(tmp_path / "raw"), "--out", str(tmp_path / "runs"),
                         "--no-llm", "--no-replay", "--run-id", "r1"])
    assert exited.value.code == 130
    err = capsys.readouterr().err
    assert "interrupted after 1 new scenarios of run r1" in err and "--run-id r1" in err
    assert len(list((tmp_path / "runs" / "r1").glob("*/status.json"))) == 1
    assert not (tmp_path / "runs" / "r1" / ".staging").exists()


# -- 4. a console that tells the truth ---------------------------------------------------------

def test_run_prints_its_line_then_problems_counted_with_the_first_few(mixed, tmp_path):
    result = invoke("run", mixed, "--out", tmp_path, "--no-llm", "--no-replay")
    out = result.stdout.splitlines()
    assert out[0].startswith("run ") and "1 ok" in out[0] and "5 refused" in out[0]
    started, *err = result.stderr.splitlines()
    assert started.startswith("run ") and "--run-id" in started  # the id to resume by, said first
    assert err[0] == "refused: 5 records (5 input errors)"
    assert err[1].startswith("  BRAKE_BINS_VALUES.npy, row 0, field 'delta_vel_kmh': ")
    assert err[4].startswith("  and 2 more — see ") and err[4].endswith("summary.json")


# -- 5. output you can trust -------------------------------------------------------------------

def test_reingesting_replaces_the_records_of_the_last_ingest(tmp_path):
    write_npy(tmp_path / "raw", "LCF", GOOD_LCF)
    ingest_directory(tmp_path / "raw", tmp_path / "rec")
    (tmp_path / "raw" / "LCF_BINS_VALUES.npy").unlink()
    write_npy(tmp_path / "raw", "LCB", GOOD_LCF)
    ingest_directory(tmp_path / "raw", tmp_path / "rec")
    assert sorted(p.name for p in (tmp_path / "rec" / "highway").iterdir()) == ["LCB.json"]


def test_a_run_that_stops_before_its_first_scenario_leaves_no_folder(mixed, tmp_path,
                                                                    monkeypatch):
    from scenweave import runner

    def broken(*args, **kwargs):
        raise RuntimeError("the map is broken")

    monkeypatch.setattr(runner, "_in_this_process", broken)
    result = invoke("run", mixed, "--classes", "LCF", "--out", tmp_path / "runs", "--no-llm",
                    "--no-replay", "--run-id", "x")
    assert result.exit_code == 1 and not (tmp_path / "runs" / "x").exists()


@pytest.mark.parametrize("umask, file_mode, dir_mode", [(0o022, 0o644, 0o755),
                                                         (0o027, 0o640, 0o750)])
def test_files_have_the_users_umask_modes(mixed, tmp_path, umask, file_mode, dir_mode):
    script = (f"import os, sys; os.umask({umask}); from scenweave.cli import main; "
              f"main(sys.argv[1:])")
    subprocess.run([sys.executable, "-c", script, "run", str(mixed), "--classes", "LCF",
                    "--out", str(tmp_path), "--no-llm", "--no-replay", "--run-id", "m"],
                   check=True, capture_output=True)
    run = tmp_path / "m"
    files = [run / "summary.json", run / "report.html", *run.glob("*/scenario.xosc"),
             *run.glob("*/status.json")]
    assert len(files) == 4
    assert {oct(stat.S_IMODE(p.stat().st_mode)) for p in files} == {oct(file_mode)}
    folders = [run, *(p for p in run.iterdir() if p.is_dir())]
    assert {oct(stat.S_IMODE(p.stat().st_mode)) for p in folders} == {oct(dir_mode)}


# -- 6. one vocabulary --------------------------------------------------------------------------

def _command(name: str) -> click.Command:
    return cli.get_command(click.Context(cli), name)


def test_every_command_running_the_agent_takes_the_same_llm_choices():
    for name in ("run", "submit", "demo", "bench"):
        [option] = [p for p in _command(name).params if p.name == "llm"]
        assert isinstance(option.type, LlmChoice), name
        assert tuple(option.type.choices) == LLM_CHOICES, name


def test_every_listing_and_summary_command_has_json_with_one_meaning():
    listing = ("run", "ingest", "mine", "replay", "validate", "bench", "logs", "trace",
               "doctor", "sample-data", "report", "sandbox", "collect")
    for name in listing:
        command = _command(name)
        commands = command.commands.values() if isinstance(command, click.Group) else [command]
        options = [p for c in commands for p in c.params if "--json" in getattr(p, "opts", [])]
        assert options, name
        assert all(o.help.endswith("as JSON instead of the human lines.") for o in options)


def test_verbose_is_taken_after_the_subcommand_too(tmp_path, capsys):
    with pytest.raises(SystemExit) as exited:
        cli_module.main(["ingest", str(tmp_path), "--out", str(tmp_path / "o"), "--verbose"])
    assert exited.value.code == 1  # no data: nothing written, not a usage error
    assert "no such option" not in capsys.readouterr().err


def test_documented_defaults_are_the_real_ones():
    from scenweave.agent.settings import DEFAULT_MAX_TOKENS, AgentSettings

    options = {p.name: p for p in _command("run").params}
    assert (f"{DEFAULT_MAX_TOKENS['ollama']} Ollama, {DEFAULT_MAX_TOKENS['embedded']} embedded"
            in options["max_tokens"].help)
    real = AgentSettings()
    assert options["llm_timeout"].default == real.timeout_s
    assert options["num_ctx"].default == real.num_ctx
    assert options["max_attempts"].default == real.max_attempts
    assert options["repair"].default.replace("-", "_") == real.repair


def test_logs_filter_by_run_model_and_scenario_and_preview_the_reply(tmp_path, monkeypatch):
    from scenweave.agent.llm.log import log_call, recent_calls
    from scenweave.agent.llm.messages import LLMReply, Prompt

    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path))
    script = "```python\nimport json\nfrom x import y\n\nSPEED = 13.9  # the record's\n```"
    log_call(Prompt("s", "u", "BRAKE_1"), LLMReply(script, model="m1", backend="ollama"), "r1")
    log_call(Prompt("s", "u", "LCF_1"), LLMReply("{}", model="m2", backend="ollama"), "r2")
    assert [c["scenario_id"] for c in recent_calls(run_id="r1")] == ["BRAKE_1"]
    assert [c["scenario_id"] for c in recent_calls(model="m2")] == ["LCF_1"]
    assert recent_calls(run_id="r1", model="m2") == []
    shown = invoke("logs", "--run", "r1")
    assert "run r1" in shown.output and "SPEED = 13.9 # the record's" in shown.output
    assert reply_preview(script) == "SPEED = 13.9 # the record's"


def test_the_demo_line_counts_the_failed_llm_attempts_by_kind():
    summary = {"attempts": 6, "first_attempt_success": 0,
               "error_taxonomy": {"import": 3, "syntax": 3}}
    assert attempts_line(summary) == ("agent: 6 LLM attempts, 6 failed (3 import, 3 syntax); "
                                      "0 right the first time")


# -- 7. a default that works --------------------------------------------------------------------

def test_auto_uses_ollama_when_it_answers_else_the_reference_scripts(capsys):
    from scenweave.testing.fake_ollama import FakeOllama

    with FakeOllama() as server:
        assert auto_llm(server.url) == "ollama"
    assert auto_llm("http://127.0.0.1:9") == "none"
    assert "no Ollama server answers at http://127.0.0.1:9" in capsys.readouterr().err


def test_run_without_llm_options_does_not_load_the_embedded_model(mixed, tmp_path,
                                                                  monkeypatch):
    monkeypatch.setenv("OLLAMA_HOST", "http://127.0.0.1:9")
    result = invoke("run", mixed, "--classes", "LCF", "--out", tmp_path, "--no-replay",
                    "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["counts"]["ok"] == 1 and summary["attempts"] == 1
    run = json.loads((tmp_path / summary["run_id"] / "run.json").read_text())
    assert run["mode"] == "no-llm"
    assert "running the reference scripts" in result.stderr


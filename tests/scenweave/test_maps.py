"""``--map``: the sample data on other CARLA towns, end to end through the CLI, replay included."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave import maneuvers
from scenweave.cli import cli
from scenweave.roads import BUNDLED_MAPS_DIR

URBAN = "U1_1,U4_1,U4_2,U4_3,U4_4"


@pytest.fixture(scope="module")
def home(tmp_path_factory):
    """One $SCENWEAVE_HOME for the module: each map's spawn database is built once."""
    path = tmp_path_factory.mktemp("home")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SCENWEAVE_HOME", str(path))
        yield path


@pytest.fixture(scope="module")
def data(tmp_path_factory, home) -> Path:
    """The README's sample data: seed 7, 3 records per class (51 records)."""
    path = tmp_path_factory.mktemp("sample") / "data"
    made = CliRunner().invoke(cli, ["sample-data", str(path), "--seed", "7", "--per-class", "3"])
    assert made.exit_code == 0, made.output
    return path


def run(data: Path, out: Path, *options: str):
    result = CliRunner().invoke(cli, ["run", str(data), "--out", str(out), "--no-llm",
                                      "--run-id", "r", "--json", *options])
    summary = json.loads(result.stdout) if result.exit_code == 0 else None
    return result, summary


@pytest.mark.parametrize("command", [
    ["run", "."], ["submit", "."], ["bench", "--models", "reference"], ["replay", "."],
    ["worker"], ["spawn-db", "build"], ["spawn-db", "show"]])
def test_an_unknown_map_is_one_error_naming_the_option(command, home):
    result = CliRunner().invoke(cli, [*command, "--map", "Town03"])
    assert result.exit_code == 2
    assert "Invalid value for '--map': unknown map 'Town03': bundled maps are Town01" \
        in result.output


def test_a_map_file_is_named_by_its_path_in_logic_file(data, tmp_path):
    mine = tmp_path / "Mine.xodr"
    shutil.copy(BUNDLED_MAPS_DIR / "Town02.xodr", mine)
    result, summary = run(data, tmp_path / "runs", "--map", str(mine), "--classes", "U4_1",
                          "--per-class", "1", "--no-replay")
    assert summary and summary["counts"]["ok"] == 1, result.output
    folder = next((tmp_path / "runs" / "r").glob("U4_1*"))
    assert json.loads((folder / "params.json").read_text())["map"] == str(mine)
    assert f'<LogicFile filepath="{mine}" />' in (folder / "scenario.xosc").read_text()
    assert json.loads((tmp_path / "runs" / "r" / "run.json").read_text())["map"] == str(mine)


def test_a_highway_record_on_a_town_without_highway_is_one_line_and_the_batch_goes_on(
        data, tmp_path):
    result = CliRunner().invoke(cli, ["run", str(data), "--out", str(tmp_path), "--no-llm",
                                      "--no-replay", "--map", "Town01", "--classes", "BRAKE,U4_1"])
    assert result.exit_code == 1, result.output  # three scenarios failed
    started, *lines = result.stderr.splitlines()
    assert started.startswith("run ")  # the line naming the run's id comes first
    assert lines[0] == "failed: 3 scenarios (spawn 3)"
    assert lines[1:] == [f"  NoSpawnFits: BRAKE_B0_BRAKE_BINS_VALUES_row00000{row} (BRAKE): map "
                         "Town01 has no highway lane that fits (no highway spawn point in its "
                         "spawn database)" for row in range(3)]
    assert "3 ok, 0 repaired, 0 fallback, 3 failed" in result.stdout


@pytest.mark.slow
def test_the_sample_data_plays_as_recorded_on_town06(data, tmp_path, esmini):
    result, summary = run(data, tmp_path, "--map", "Town06", "--replay")
    assert summary, result.output
    failed = {o["scenario_id"]: o["error"] for o in summary["scenarios"] if o["status"] != "ok"}
    assert not failed
    assert sorted(summary["by_class"]) == maneuvers.codes()
    assert summary["replay"]["played"] == summary["replay"]["passed"] == summary["total"]


@pytest.mark.slow
@pytest.mark.parametrize("town", ["Town01", "Town02", "Town07", "Town10HD"])
def test_urban_classes_play_as_recorded_on_the_small_towns(town, data, tmp_path, esmini):
    result, summary = run(data, tmp_path, "--map", town, "--classes", URBAN, "--replay")
    assert summary, result.output
    failed = {o["scenario_id"]: o["error"] for o in summary["scenarios"] if o["status"] != "ok"}
    assert not failed
    assert summary["replay"]["played"] == summary["replay"]["passed"] == summary["total"] == 15
    logic = {f'filepath="{town}"' in p.read_text()
             for p in (tmp_path / "r").glob("*/scenario.xosc")}
    assert logic == {True}

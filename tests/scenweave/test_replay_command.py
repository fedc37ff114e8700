"""``scenweave replay RUN_DIR | FILE.xosc...`` from the command line, in the real esmini."""

from __future__ import annotations

import json
import shutil

import pytest
from click.testing import CliRunner
from lxml import etree

from scenweave.cli import cli
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.runner import run_batch

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("esmini")]


@pytest.fixture(scope="module")
def run_dir(sample_raw, tmp_path_factory):
    """Three scenarios made without the replay stage."""
    out = tmp_path_factory.mktemp("runs")
    run_batch(sample_raw, out, InputSelection(classes=("CINF", "U4_4"), per_class=1),
              PipelineSettings(no_llm=True), run_id="quiet")
    return out / "quiet"


def test_a_run_folder_is_played_and_judged_against_each_params(run_dir, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    result = CliRunner().invoke(cli, ["replay", str(run), "--json"])
    assert result.exit_code == 0, result.output
    lines = json.loads(result.output)
    assert {line["scenario"] for line in lines} == {p.name for p in run.iterdir()
                                                    if (p / "scenario.xosc").is_file()}
    assert all(line["played"] and line["passed"] for line in lines), lines
    assert all((run / line["scenario"] / "replay.json").is_file() for line in lines)


def test_a_failing_replay_is_one_line_with_what_happened(run_dir, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    cinf = next(p for p in run.iterdir() if p.name.startswith("CINF"))
    tree = etree.parse(str(cinf / "scenario.xosc"))
    (performance,) = tree.getroot().xpath("//ScenarioObject[@name='npc']//Performance")
    performance.set("maxSpeed", "10")  # valid and faithful to every number; the engine caps it
    tree.write(str(cinf / "scenario.xosc"), xml_declaration=True, encoding="utf-8")
    result = CliRunner().invoke(cli, ["replay", str(run)])
    assert result.exit_code == 1, result.output  # one did not play as recorded
    fails = [line for line in result.output.splitlines() if line.startswith("FAIL")]
    assert len(fails) == 1 and cinf.name in fails[0] and "REPLAY_START_SPEED" in fails[0]
    assert result.output.strip().endswith("replay: 1/2 played as recorded")


def test_a_lone_file_without_params_is_played_for_engine_errors_and_collisions(run_dir,
                                                                               tmp_path):
    lone = tmp_path / "lone.xosc"
    shutil.copy(next(run_dir.glob("U4_4*/scenario.xosc")), lone)
    result = CliRunner().invoke(cli, ["replay", str(lone), "--json"])
    assert result.exit_code == 0, result.output
    (line,) = json.loads(result.output)
    assert line == {**line, "played": True, "passed": True, "codes": []}
    assert (tmp_path / "replay.json").is_file()

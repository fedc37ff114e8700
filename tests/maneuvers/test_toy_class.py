"""RQ3: a new manoeuvre class needs no change to ScenWeave. The toy class ACCEL (this test's
folder only: its definition in ``toy/accel.py``, its reference script next to it) goes from
sample data through ingest, spawn, reference script, checks and the esmini replay to ok."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave import maneuvers
from scenweave.cli import cli

TOY = Path(__file__).parent / "toy" / "accel.py"


@pytest.fixture
def toy_class(monkeypatch):
    monkeypatch.setenv(maneuvers.PLUGINS_ENV, str(TOY))
    yield maneuvers.get("ACCEL")
    maneuvers.unregister("ACCEL")


def test_the_plugin_registers_the_class(toy_class):
    assert toy_class.code in maneuvers.codes("highway")
    assert maneuvers.by_tag("lead_accelerates") is toy_class


def test_a_toy_class_runs_end_to_end_and_replays_as_recorded(toy_class, esmini, tmp_path):
    runner = CliRunner()
    made = runner.invoke(cli, ["sample-data", str(tmp_path / "raw"), "--seed", "3",
                               "--per-class", "3"])
    assert made.exit_code == 0, made.output
    assert (tmp_path / "raw" / "highway" / "ACCEL_BINS_VALUES.npy").exists()
    ran = runner.invoke(cli, ["run", str(tmp_path / "raw"), "--no-llm", "--classes", "ACCEL",
                              "--out", str(tmp_path / "runs"), "--run-id", "toy"])
    assert ran.exit_code == 0, ran.output
    summary = json.loads((tmp_path / "runs" / "toy" / "summary.json").read_text())
    outcomes = summary["scenarios"]
    assert len(outcomes) == 3 and not summary["input_issues"]
    assert all(o["status"] == "ok" for o in outcomes), outcomes
    folder = tmp_path / "runs" / "toy" / outcomes[0]["scenario_id"]
    replay = json.loads((folder / "replay.json").read_text())
    assert replay["tracks"]["npc"], "the lead was played"
    scenario = (folder / "scenario.xosc").read_text()
    assert "npc_speed_change" in scenario and "ScenWeave ACCEL" in scenario


def test_without_the_plugin_the_class_is_unknown_in_one_line(tmp_path):
    with pytest.raises(maneuvers.UnknownManeuver, match="unknown manoeuvre class 'ACCEL'.*"
                       r"\$SCENWEAVE_PLUGINS, see docs/plugins.md"):
        maneuvers.get("ACCEL")


def test_the_old_variable_still_loads_the_class_with_one_warning(monkeypatch):
    """``$SCENWEAVE_MANEUVERS`` (the first plugin mechanism) works for one more release."""
    from scenweave import plugins

    monkeypatch.setattr(plugins, "_warned_deprecated", False)
    monkeypatch.setenv(plugins.DEPRECATED_ENV, str(TOY))
    try:
        with pytest.warns(FutureWarning, match=r"SCENWEAVE_MANEUVERS is deprecated.*"
                                               r"SCENWEAVE_PLUGINS") as warned:
            assert maneuvers.get("ACCEL").tag == "lead_accelerates"
            assert "ACCEL" in maneuvers.codes("highway")
    finally:
        maneuvers.unregister("ACCEL")
    assert len(warned) == 1


def test_a_plugin_class_ships_the_example_its_worked_example_shows(toy_class, tmp_path,
                                                                   monkeypatch):
    """The LLM adapts a worked example: a plugin's comes from its own ``example`` params."""
    import dataclasses

    from scenweave.corpus.retrieval import script_path
    from scenweave.corpus.worked_example import adaptation
    from scenweave.inputs import InputSelection, load_input
    from scenweave.spawn_db import SpawnMatcher

    CliRunner().invoke(cli, ["sample-data", str(tmp_path / "raw"), "--per-class", "2"])
    loaded = load_input(tmp_path / "raw", InputSelection(classes=("ACCEL",)))
    example, record = (SpawnMatcher().assign(p, i) for i, p in enumerate(loaded.params))
    monkeypatch.delenv(maneuvers.PLUGINS_ENV)  # registered by hand now, with its example
    maneuvers.unregister("ACCEL")
    maneuvers.register(dataclasses.replace(toy_class, example=example))
    shown, values = adaptation(script_path(toy_class), record)
    assert repr(example["npc_end_speed_ms"]) in shown  # the example's values, written in
    assert repr(record["npc_end_speed_ms"]) not in shown
    assert values["npc_end_speed_ms"] == record["npc_end_speed_ms"]  # the record's, by key


def test_retrieval_asks_the_registry_before_script_names(toy_class):
    """A plugin class coded STOP gets its own script, not gen_ur_stop_at_tfl_red.py whose
    name holds its code."""
    import dataclasses

    from scenweave.corpus import retrieve

    maneuvers.register(dataclasses.replace(toy_class, code="STOP", tag="lead_speeds_off"))
    try:
        found = retrieve({"maneuver_class": "STOP", "maneuver_tag": "lead_speeds_off"})
    finally:
        maneuvers.unregister("STOP")
    assert (found.script_path.name, found.method) == ("gen_hw_accel.py", "tag")


def test_a_plugin_urban_class_spawns_and_replays_ok(monkeypatch, esmini, tmp_path):
    """Which urban classes suit a spawn point is decided when a scenario is matched, not when
    the (shipped, cached) spawn database was built: a class added later spawns too."""
    monkeypatch.setenv(maneuvers.PLUGINS_ENV, str(TOY.with_name("creep.py")))
    try:
        runner = CliRunner()
        made = runner.invoke(cli, ["sample-data", str(tmp_path / "raw"), "--seed", "3",
                                   "--per-class", "2"])
        assert made.exit_code == 0, made.output
        ran = runner.invoke(cli, ["run", str(tmp_path / "raw"), "--no-llm", "--classes", "U9_1",
                                  "--out", str(tmp_path / "runs"), "--run-id", "creep"])
    finally:
        maneuvers.unregister("U9_1")
    assert ran.exit_code == 0, ran.output
    summary = json.loads((tmp_path / "runs" / "creep" / "summary.json").read_text())
    assert [o["status"] for o in summary["scenarios"]] == ["ok", "ok"]
    assert summary["replay"]["passed"] == 2

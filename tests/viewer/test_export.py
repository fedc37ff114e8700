"""``scenweave export`` (esmini: the copy plain esmini plays, with a recording; CARLA: the
delivered files and a README), ``scenweave replay --force`` and what the viewer reads from a
folder (``replay.json`` alone is enough to watch)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.player import find_esmini
from scenweave.viewer.scene import scene
from tests.viewer.runs import CUT_IN, EDITED_SLOWER_MS

pytestmark = pytest.mark.slow


def plain_esmini(scenario: Path) -> subprocess.CompletedProcess:
    """The scenario played by esmini's own command-line player, nothing of ours around it."""
    return subprocess.run([str(find_esmini().home / "bin" / "esmini"), "--headless", "--osc",
                           str(scenario), "--disable_log"], capture_output=True, text=True,
                          timeout=120, check=False)


def test_every_exported_esmini_copy_plays_in_plain_esmini(viewer_runs, tmp_path):
    out = tmp_path / "esmini"
    result = CliRunner().invoke(cli, ["export", str(viewer_runs["run"]), str(viewer_runs["edited"]
                                      / "scenario.xosc"), "--for", "esmini", "--out", str(out)])
    assert result.exit_code == 0, result.output
    scenarios = sorted(out.glob("*/scenario.xosc"))
    delivered = sorted(p for p in viewer_runs["run"].glob("*/scenario.xosc"))
    assert len(scenarios) == len(delivered) + 1
    moved = tmp_path / "moved"
    shutil.move(out, moved)  # the map is named relative to the scenario: the folder travels
    for scenario in sorted(moved.glob("*/scenario.xosc")):
        played = plain_esmini(scenario)
        assert played.returncode == 0, played.stdout[-2000:]
        assert "completeState" in played.stdout and "Failed to" not in played.stdout
        assert (scenario.parent / "replay.dat").stat().st_size > 1000
    # the delivered file is CARLA's and names the town, which plain esmini cannot find
    assert "Failed to locate OpenDRIVE file" in plain_esmini(delivered[0]).stdout


def test_the_carla_export_holds_the_delivered_files_and_says_how_to_run_them(viewer_runs,
                                                                             tmp_path):
    out = tmp_path / "carla"
    result = CliRunner().invoke(cli, ["export", str(viewer_runs["run"]), "--for", "carla",
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    for folder in (p for p in viewer_runs["run"].iterdir() if (p / "scenario.xosc").is_file()):
        for name in ("scenario.xosc", "scenario.py", "params.json"):
            assert (out / folder.name / name).read_bytes() == (folder / name).read_bytes()
    readme = (out / "README.md").read_text()
    assert "scenario_runner.py --openscenario" in readme
    assert f"| `{CUT_IN}/scenario.xosc` | Town04 |" in readme


def test_replay_force_plays_a_file_that_fails_the_parameter_checks(viewer_runs, tmp_path):
    folder = tmp_path / "edited"
    shutil.copytree(viewer_runs["edited"], folder)
    (folder / "replay.json").unlink()
    refused = CliRunner().invoke(cli, ["replay", str(folder / "scenario.xosc")])
    assert "FIDELITY_SPEED" in refused.output and not (folder / "replay.json").exists()
    forced = CliRunner().invoke(cli, ["replay", str(folder / "scenario.xosc"), "--force"])
    assert "FORCED edited: fails the parameter checks (FIDELITY_SPEED" in forced.output
    assert "REPLAY_SPEED" in forced.output
    speeds = json.loads((folder / "replay.json").read_text())["tracks"]["npc"]["speed"]
    params = json.loads((folder / "params.json").read_text())
    assert speeds[-1] == pytest.approx(params["npc_end_speed_ms"] - EDITED_SLOWER_MS, abs=0.05)


def test_a_scenario_is_watchable_from_its_replay_json_alone(viewer_runs, tmp_path):
    folder = tmp_path / "only-replay"
    folder.mkdir()
    shutil.copy(viewer_runs["run"] / CUT_IN / "replay.json", folder)
    watched = scene(folder)
    assert watched["played"] and watched["map"] == "Town04"
    assert set(watched["actors"]) == {"hero", "npc"} and len(watched["lanes"]) > 10
    assert all(len(actor["box"]) == 3 for actor in watched["actors"].values())
    urban = next(p for p in viewer_runs["run"].iterdir() if p.name.startswith("U4_1"))
    shutil.copy(urban / "replay.json", folder)
    lights = scene(folder)["lights"]
    assert lights and {span[2] for span in lights[0]["spans"]} >= {"red"}

"""``scenweave run --matcher``: the batch places its records with the matcher named (a
registered name or ``module:callable``), as ``submit`` and ``worker`` do, not silently with
the default one."""

from __future__ import annotations

import json
import textwrap

from click.testing import CliRunner

from scenweave.cli import cli

TOY = """
    from scenweave.spawn_db import NoSpawnFits

    MADE = []


    class Nowhere:
        def assign(self, params, index, top_n=5):
            raise NoSpawnFits(f"{params['scenario_id']}: the toy matcher places nothing")


    def make(map_name):
        MADE.append(map_name)
        return Nowhere()
"""


def test_run_places_with_the_matcher_module_callable_names(sample_raw, tmp_path, monkeypatch):
    (tmp_path / "toy_run_matcher.py").write_text(textwrap.dedent(TOY), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    done = CliRunner().invoke(cli, [
        "run", str(sample_raw / "highway"), "--out", str(tmp_path / "runs"), "--no-llm",
        "--run-id", "toy", "--limit", "2", "--map", "Town06",
        "--matcher", "toy_run_matcher:make"])
    import toy_run_matcher

    assert done.exit_code == 1, done.output  # every scenario failed: nothing was placed
    assert toy_run_matcher.MADE == ["Town06"], "made once, for the run's map"
    summary = json.loads((tmp_path / "runs" / "toy" / "summary.json").read_text())
    assert [(o["status"], o["error_taxonomy"]) for o in summary["scenarios"]] == [
        ("failed", ["spawn"])] * 2
    assert all("the toy matcher places nothing" in o["error"] for o in summary["scenarios"])


def test_run_refuses_a_matcher_it_cannot_make(sample_raw, tmp_path):
    done = CliRunner().invoke(cli, ["run", str(sample_raw / "highway"), "--no-llm",
                                    "--out", str(tmp_path), "--matcher", "nowhere"])
    assert done.exit_code == 2
    assert "--matcher 'nowhere': no such spawn matcher (choose default" in done.output
    assert not any(tmp_path.iterdir()), "no run folder for a run that cannot start"

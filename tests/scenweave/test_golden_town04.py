"""Refactors keep behaviour: the sample data's Town04 scenarios stay byte-identical.

`tests/golden/town04_no_llm.json` holds the sha256 of every `scenario.xosc` that
`scenweave run --no-llm` made from the built-in sample data (seed 7, 3 per class) before the
registry / map / namespace work of issue 13. A change that alters a single byte of any of
them fails here, naming the scenarios. A class added since (built in or a plugin) has sample
data and scenarios of its own, drawn from its own random stream, which are not compared.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from click.testing import CliRunner

from scenweave import maneuvers
from scenweave.cli import cli

GOLDEN = Path(__file__).parents[1] / "golden" / "town04_no_llm.json"


def test_sample_data_gives_byte_identical_town04_scenarios(tmp_path: Path) -> None:
    golden = json.loads(GOLDEN.read_text())["scenario_sha256"]
    runner = CliRunner()
    made = runner.invoke(cli, ["sample-data", str(tmp_path / "data"), "--seed", "7",
                                "--per-class", "3"])
    assert made.exit_code == 0, made.output
    ran = runner.invoke(cli, ["run", str(tmp_path / "data"), "--out", str(tmp_path / "runs"),
                               "--no-llm", "--no-replay", "--run-id", "golden"])
    assert ran.exit_code == 0, ran.output
    run_dir = tmp_path / "runs" / "golden"
    now = {p.parent.name: hashlib.sha256(p.read_bytes()).hexdigest()
           for p in run_dir.glob("*/scenario.xosc")}
    known = {_class_of(name) for name in golden}
    assert sorted(name for name in now if _class_of(name) in known) == sorted(golden), \
        "the sample data no longer makes the same scenarios"
    changed = sorted(name for name in golden if now[name] != golden[name])
    assert not changed, f"{len(changed)} scenarios changed, e.g. {changed[:5]}"


def _class_of(scenario_id: str) -> str:
    """The class code a sample scenario id starts with (a class added since the golden was
    made has scenarios of its own, which the golden cannot hold)."""
    return next(code for code in sorted(maneuvers.codes(), key=len, reverse=True)
                if scenario_id.startswith(f"{code}_"))

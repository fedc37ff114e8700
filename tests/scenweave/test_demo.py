"""``scenweave demo``, the README's main job, from the command line (reference part only: the
embedded-model part is the agent's end-to-end test)."""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave import maneuvers
from scenweave.cli import cli
from scenweave.commands.demo import PHASED_ROWS

CLASSES = len(maneuvers.codes())
#: the demo's rows that need a speed profile of two phases (issue 22): one per FL class
SCENARIOS = CLASSES + PHASED_ROWS * sum(1 for m in maneuvers.maneuvers() if m.sample_phased)


def test_demo_makes_ingests_and_validates_every_class(tmp_path):
    out = tmp_path / "demo"
    outcome = CliRunner().invoke(cli, ["demo", "--out", str(out), "--per-class", "1",
                                       "--llm", "none"])
    assert outcome.exit_code == 0, outcome.output

    records = [p for p in (out / "records").rglob("*.json") if p.name != "ingest_report.json"]
    assert len(records) == CLASSES
    run = out / "runs" / "no-llm"
    summary = json.loads((run / "summary.json").read_text())
    statuses = [s["status"] for s in summary["scenarios"]]
    assert statuses == ["ok"] * SCENARIOS
    assert len({s["maneuver_class"] for s in summary["scenarios"]}) == CLASSES
    assert (run / "report.html").stat().st_size > 0
    assert f"{SCENARIOS} scenarios: {SCENARIOS} ok" in outcome.output
    assert str(run) in outcome.output.strip().splitlines()[-1]

"""The ingest-stage commands as a user runs them."""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave import maneuvers
from scenweave.cli import cli


def test_sample_data_then_ingest_gives_records_for_all_17_classes(tmp_path):
    runner = CliRunner()
    made = runner.invoke(cli, ["sample-data", str(tmp_path / "raw"), "--per-class", "3",
                               "--seed", "9"])
    assert made.exit_code == 0, made.output
    assert f"{len(maneuvers.codes('highway'))} highway files" in made.output
    done = runner.invoke(cli, ["ingest", str(tmp_path / "raw"), "--out", str(tmp_path / "rec"),
                               "--json"])
    assert done.exit_code == 0, done.output
    report = json.loads(done.output)
    assert sorted(report["records_by_class"]) == maneuvers.codes() and report["errors"] == 0
    assert sorted(p.stem for p in (tmp_path / "rec" / "urban").iterdir()) == maneuvers.codes(
        "urban")

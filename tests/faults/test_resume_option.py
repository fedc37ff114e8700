"""``scenweave run DATA --resume`` finds the run last started on the same input with the same
selection (its ``run.json``), or says there is none before anything is written."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.inputs import InputSelection
from scenweave.runner import described_selection, latest_run_of
from scenweave.schemas.scenario_folder import RUN_FILE


def described(out: Path, run_id: str, data: str, selection: InputSelection,
              started_at: str) -> None:
    (out / run_id).mkdir(parents=True)
    (out / run_id / RUN_FILE).write_text(json.dumps({
        "run_id": run_id, "started_at": started_at, "input": data,
        "selection": described_selection(selection)}))


def test_the_latest_run_of_the_same_input_and_selection_is_found(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data").mkdir()
    out = tmp_path / "runs"
    brake = InputSelection(classes=("BRAKE",), per_class=2)
    described(out, "older", "data", brake, "2026-11-28T10:00:00+00:00")
    described(out, "newer", str(tmp_path / "data"), brake, "2026-11-28T11:00:00+00:00")
    described(out, "other-classes", "data", InputSelection(classes=("LCF",), per_class=2),
              "2026-11-28T12:00:00+00:00")
    described(out, "other-input", "elsewhere", brake, "2026-11-28T12:00:00+00:00")
    (out / "damaged").mkdir()
    (out / "damaged" / RUN_FILE).write_text('{"input": ')
    assert latest_run_of(Path("data"), out, brake) == "newer"  # relative or absolute alike
    assert latest_run_of(Path("data"), out, InputSelection(classes=("LCF",), per_class=2)) \
        == "other-classes"
    assert latest_run_of(Path("data"), out, InputSelection()) is None


def test_resume_without_a_run_to_resume_is_a_usage_error_that_writes_nothing(tmp_path):
    (tmp_path / "data").mkdir()
    out = tmp_path / "runs"
    result = CliRunner().invoke(cli, ["run", str(tmp_path / "data"), "--out", str(out),
                                      "--no-llm", "--resume"])
    assert result.exit_code == 2
    assert f"--resume: no run of {tmp_path / 'data'} with this selection in {out} to resume " \
           "(drop --resume to start one)" in result.output
    assert not out.exists()
    both = CliRunner().invoke(cli, ["run", str(tmp_path / "data"), "--out", str(out),
                                    "--no-llm", "--resume", "--run-id", "x"])
    assert both.exit_code == 2 and "pass one" in both.output

"""A resume trusts a scenario folder only when it holds what its status.json names: a
truncated status.json, a deleted scenario.xosc and a damaged params.json are each made again,
with one line naming the scenario and why; whole folders are left as they are. A run stopped
by an error (a full disk) says which run it was and the one step that resumes it."""

from __future__ import annotations

import errno
import json

import pytest

from scenweave.run_folder import RunFolder
from scenweave.testing.faults import FaultBench
from scenweave.testing.run_faults import damaged_on_resume


def test_damaged_folders_are_made_again_and_named(tmp_path):
    bench = FaultBench.make(tmp_path, per_class=2)
    redone, (truncated, unxosc, unparams) = damaged_on_resume(bench)
    assert redone.exit_codes == [0, 0], redone.output
    assert (redone.expected, redone.once, redone.lost, redone.doubled) == (8, 8, 0, 0)
    assert redone.damaged == [] and redone.not_ok == [], redone.output
    assert f"{unxosc} is made again: its status.json says ok but scenario.xosc is " \
           "missing" in redone.output
    assert f"{unparams} is made again" in redone.output and "params.json is damaged" \
        in redone.output
    assert "(5 already done" in redone.output, redone.output
    run = tmp_path / "runs-damaged" / "damaged"
    for name in (truncated, unxosc, unparams):
        assert json.loads((run / name / "status.json").read_text())["status"] == "ok"
    summary = json.loads((run / "summary.json").read_text())
    assert summary["total"] == 8
    assert sorted(o["scenario_id"] for o in summary["scenarios"]) == sorted(
        json.loads(p.read_text())["scenario_id"] for p in run.glob("*/status.json"))


def test_a_run_stopped_by_an_error_names_itself_and_how_to_resume(tmp_path):
    folder = RunFolder.open(tmp_path, "full")
    with pytest.raises(OSError) as stopped, folder.started() as started:
        (folder.root / "A").mkdir()
        (folder.root / "A" / "status.json").write_text('{"scenario_id": "A", "status": "ok"}')
        started.committed += 1
        raise OSError(errno.ENOSPC, "No space left on device")
    # a note the command line prints on the error's one line
    assert stopped.value.__notes__ == [
        f"run full stopped: the disk holding {folder.root} is full; 1 scenarios are kept "
        "there (1 new): free some space, then run the same command with --run-id full to resume"]
    assert (folder.root / "A" / "status.json").is_file()
    with pytest.raises(RuntimeError) as other, folder.started():
        raise RuntimeError("the LLM server is gone")
    assert other.value.__notes__ == [
        f"run full stopped (RuntimeError) after 0 new scenarios, 1 in {folder.root}; they are "
        "kept: run the same command with --run-id full to resume"]

"""A resume trusts a scenario folder only when it holds what its status.json names: a
truncated status.json, a deleted scenario.xosc and a damaged params.json are each made again,
with one line naming the scenario and why; whole folders are left as they are. A run stopped
by an error (a full disk) says which run it was and the one step that resumes it."""

from __future__ import annotations

import errno
import json
import subprocess
import sys
from pathlib import Path

import pytest

from scenweave.run_folder import RunFolder

CLI = [sys.executable, "-m", "scenweave.cli"]


def run(records: Path, out: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, "run", str(records), "--no-llm", "--out", str(out), "--run-id",
                           "r", "--classes", "BRAKE,LCF"], capture_output=True, text=True,
                          timeout=300)


def test_damaged_folders_are_made_again_and_named(sample_raw, tmp_path):
    first = run(sample_raw, tmp_path)
    assert first.returncode == 0, first.stdout + first.stderr
    folders = sorted(p.parent for p in (tmp_path / "r").glob("*/status.json"))
    assert len(folders) == 6
    truncated, unxosc, unparams, whole = folders[0], folders[1], folders[2], folders[3]
    (truncated / "status.json").write_text('{"scenario_id": ')
    (unxosc / "scenario.xosc").unlink()
    (unparams / "params.json").write_text("[1, 2")
    untouched = (whole / "status.json").stat().st_mtime_ns

    again = run(sample_raw, tmp_path)
    assert again.returncode == 0, again.stdout + again.stderr
    assert f"{unxosc.name} is made again: its status.json says ok but scenario.xosc is " \
           "missing" in again.stderr
    assert f"{unparams.name} is made again" in again.stderr and "params.json is damaged" \
        in again.stderr
    assert "(3 already done" in again.stdout, again.stdout
    for folder in folders:
        assert json.loads((folder / "status.json").read_text())["status"] == "ok"
        assert (folder / "scenario.xosc").is_file()
        assert isinstance(json.loads((folder / "params.json").read_text()), dict)
    assert (whole / "status.json").stat().st_mtime_ns == untouched
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["total"] == 6
    assert sorted(o["scenario_id"] for o in summary["scenarios"]) == sorted(
        json.loads((f / "status.json").read_text())["scenario_id"] for f in folders)


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

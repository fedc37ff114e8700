"""A resume trusts a scenario folder only when it holds what its status.json names: a
truncated status.json, a deleted scenario.xosc and a damaged params.json are each made again,
with one line naming the scenario and why; whole folders are left as they are."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

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

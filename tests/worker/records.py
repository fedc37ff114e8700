"""Canonical records of the sample data with one poisoned record, for the worker and report
tests: BRAKE row 1 asks for a gap no Town04 spawn fits, so that scenario fails alone."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from scenweave.cli import cli

BRAKE = [f"BRAKE_B0_BRAKE_BINS_VALUES_row00000{i}" for i in range(3)]
LCF = [f"LCF_B0_LCF_BINS_VALUES_row00000{i}" for i in range(3)]
POISONED = BRAKE[1]
POISONED_GAP_M = 4000.0


def ingest_with_poisoned_record(raw: Path, out: Path) -> Path:
    """``scenweave ingest raw --out out``, then BRAKE row 1's gap set to 4 km; returns ``out``."""
    result = CliRunner().invoke(cli, ["ingest", str(raw), "--out", str(out)])
    assert result.exit_code == 0, result.output
    path = out / "highway" / "BRAKE.json"
    data = json.loads(path.read_text())
    assert data[1]["scenario_id"] == POISONED
    data[1]["params"]["npc_distance_m"] = POISONED_GAP_M
    path.write_text(json.dumps(data))
    return out

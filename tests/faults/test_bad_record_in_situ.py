"""``mine --in-situ``'s batch (``write_in_situ_records``) and ``run``'s writer refuse a record
that gets past the checks but breaks the making of its in-situ scenario (here a window far
past its recording: a ValueError deep in the scenario builder) with one line naming the
scenario and the file, and go on with the next record; both word it with the one helper
(``mining.in_situ.refusal``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.in_situ_records import InSituWriter
from scenweave.ingest import load_records

DATA = Path(__file__).resolve().parents[1] / "mining" / "data" / "commonroad_small.xml"


@pytest.fixture
def mined(tmp_path, monkeypatch) -> list[dict]:
    """The records ``scenweave mine`` finds in the small CommonRoad fixture."""
    pytest.importorskip("scenweave.mining.recorded_road")
    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path / "home"))
    result = CliRunner().invoke(cli, ["mine", str(DATA), "--out", str(tmp_path / "out")])
    records = [dict(r) for r in load_records(tmp_path / "out")]
    assert len(records) >= 2, result.output
    return records


def past_its_recording(record: dict) -> dict:
    return {**record, "provenance": {**record["provenance"], "start_s": 1e9, "end_s": 2e9}}


def test_the_mine_batch_refuses_a_bad_record_in_one_line_and_goes_on(mined, tmp_path):
    from scenweave.mining.in_situ import InSituSettings, write_in_situ_records

    bad, *good = mined
    batch = write_in_situ_records([past_its_recording(bad), *good], tmp_path / "in_situ",
                                  tmp_path / "home" / "roads",
                                  InSituSettings(context_s=1.0, replay=False))
    assert len(batch.refused) == 1, batch.refused
    line = batch.refused[0]
    assert line.startswith(f"{bad['scenario_id']}: {bad['provenance']['file']}: the in-situ "
                           "scenario could not be made: ValueError(")
    assert "\n" not in line
    assert not (tmp_path / "in_situ" / bad["scenario_id"]).exists()
    assert sorted(r.folder.name for r in batch.written) == sorted(r["scenario_id"] for r in good)


def test_runs_writer_words_the_same_refusal(mined, tmp_path):
    writer = InSituWriter(tmp_path / "home" / "roads", play=False)
    bad = past_its_recording(mined[0])
    (tmp_path / "scenario").mkdir()
    outcome = writer.write(bad, tmp_path / "scenario")
    assert list(outcome) == ["refused"]
    assert outcome["refused"].startswith(f"{bad['provenance']['file']}: the in-situ scenario "
                                         "could not be made: ValueError(")
    assert "vehicles" in writer.write(mined[1], tmp_path / "scenario")

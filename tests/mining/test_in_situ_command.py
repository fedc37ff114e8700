"""``scenweave mine --in-situ``: beside every mined record (the Town04 form, unchanged) its
in-situ scenario, the road cached in $SCENWEAVE_HOME."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli


def test_mine_in_situ_writes_one_scenario_beside_each_record(esmini, data, tmp_path,
                                                             monkeypatch):
    pytest.importorskip("scenweave.mining.recorded_road")
    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path / "home"))
    out = tmp_path / "out"
    result = CliRunner().invoke(cli, ["mine", str(data / "commonroad_small.xml"), "--out",
                                      str(out), "--in-situ", "--context-s", "1", "--json"])
    report = json.loads(result.output)
    records = [r for f in sorted(out.glob("*/*.json")) if f.parent.name != "in_situ"
               for r in json.loads(f.read_text())]
    assert records and report["records_written"] == len(records)  # the Town04 records stay
    written = {Path(w["folder"]).name for w in report["in_situ"]["written"]}
    assert written | {line.split(":")[0] for line in report["in_situ"]["refused"]} == {
        r["scenario_id"] for r in records}
    for record in records:
        if record["scenario_id"] not in written:
            continue
        folder = out / "in_situ" / record["scenario_id"]
        assert (folder / "scenario.xosc").is_file()
        start, end = json.loads((folder / "in_situ.json").read_text())["window_s"]
        event = record["provenance"]
        assert event["start_s"] - 1.1 <= start <= event["start_s"]  # 1 s of context
        assert event["end_s"] <= end + 1e-6 and end <= event["end_s"] + 1.0 + 1e-6
    assert (tmp_path / "home" / "roads").is_dir()  # the road is cached

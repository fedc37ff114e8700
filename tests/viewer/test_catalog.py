"""What the viewer reads from a run of mined records: the record's own series on the
scenario's clock, the judge's series errors in the run list, the link to the mining report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.viewer import catalog

pytestmark = pytest.mark.slow

NGSIM = Path(__file__).resolve().parents[1] / "mining" / "data" / "ngsim_small.csv"


@pytest.fixture(scope="module")
def mined_run(esmini, tmp_path_factory, monkeypatch_module) -> Path:
    root = tmp_path_factory.mktemp("mined")
    monkeypatch_module.chdir(root)  # run.json names its input as given: relative to here
    runner = CliRunner()
    mined = runner.invoke(cli, ["mine", str(NGSIM), "--out", "records"])
    assert mined.exit_code == 0, mined.output
    run = runner.invoke(cli, ["run", "records", "--no-llm", "--out", "runs", "--run-id", "mined"])
    assert "4 scenarios" in run.output, run.output
    return root / "runs"


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as patch:
        yield patch


def test_the_run_list_links_the_mining_report_and_shows_the_series_errors(mined_run):
    [row] = catalog.run_list(catalog.find_runs([mined_run]))
    assert row["mining_report"] == str((mined_run.parent / "records" /
                                        "mining_report.html").resolve())
    for scenario in row["scenarios"]:
        errors = json.loads((mined_run / "mined" / scenario["id"] / "replay.json").read_text())[
            "series_errors"]
        assert [w["quantity"] for w in scenario["worst"]] == sorted(
            errors, key=lambda q: -errors[q]["max"])[:3]


def test_the_speed_chart_carries_the_records_own_series_on_the_scenarios_clock(mined_run):
    runs = catalog.find_runs([mined_run])
    key = next(s["key"] for s in catalog.run_row(runs["mined"])["scenarios"]
               if s["maneuver_class"] == "CINF")
    detail = catalog.scenario_detail(runs, key)
    series = detail["params"]["recorded_series"]
    speed = detail["scene"]["charts"]["speed"]
    start = detail["params"]["maneuver_start_s"]
    assert speed["recorded"] == {"hero": series["ego_speed_ms"], "npc": series["npc_speed_ms"]}
    assert speed["recorded_t"] == pytest.approx([t + start for t in series["t"]])
    gap = detail["scene"]["charts"]["gap"]
    assert len(gap["recorded"]) == len(series["npc_gap_m"])
    # between reference points, as the judge measures: the bumper gap plus the ego's front
    # and the other car's rear
    assert all(r > g for r, g in zip(gap["recorded"], series["npc_gap_m"], strict=True))

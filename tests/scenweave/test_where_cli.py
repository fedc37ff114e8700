"""``--where`` as a user types it (issue 32 item 5): ``scenweave mine`` writes only the records
an expression matches, ``scenweave run`` makes scenarios of only those; a filter that matches
nothing writes nothing and says so (exit 1); a malformed expression is a usage error naming
its column (exit 2), found before anything is written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.mining.where import parse_where
from tests.mining.conftest import DATA, shared_data

CUT_INS = "thw_min_s < 1 and maneuver_class in (CINF, CINB)"


def mine(data: Path, out: Path, *extra: str) -> tuple[int, str, list[dict]]:
    """``scenweave mine`` -> exit code, output, every record written."""
    result = CliRunner().invoke(cli, ["mine", str(data), "--out", str(out), *extra])
    records = [r for path in sorted(out.glob("*/*.json")) for r in json.loads(path.read_text())]
    return result.exit_code, result.output, records


@pytest.fixture(scope="module")
def everything(tmp_path_factory) -> list[dict]:
    """Every record of the fixture folder, mined without a filter."""
    out = tmp_path_factory.mktemp("all")
    code, output, records = mine(DATA, out)
    assert code == 0, output
    return records


def test_mine_writes_exactly_the_records_the_expression_matches(everything, tmp_path):
    wanted = parse_where(CUT_INS)
    expected = sorted(r["scenario_id"] for r in everything if wanted(r))
    assert expected and len(expected) < len(everything)  # the filter has something to do
    code, output, records = mine(DATA, tmp_path / "out", "--where", CUT_INS)
    assert code == 0, output
    assert sorted(r["scenario_id"] for r in records) == expected
    assert all(r["criticality"]["thw_min_s"] < 1 for r in records)
    assert f"{len(expected)} of {len(everything)} records match" in output
    report = json.loads((tmp_path / "out" / "mining_report.json").read_text())
    assert report["where"] == CUT_INS and report["records_matching"] == len(expected)
    assert sum(report["records_not_matching"].values()) == len(everything) - len(expected)
    assert {c["scenario_id"] for c in report["criticality"]} == set(expected)


def test_a_filter_that_matches_nothing_writes_nothing_and_says_so(everything, tmp_path):
    code, output, records = mine(DATA, tmp_path / "out", "--where", "ttc_min_s < 0.01")
    assert code == 1 and records == []
    assert not (tmp_path / "out" / "highway").exists()
    assert (f"--where 'ttc_min_s < 0.01' matched none of the {len(everything)} records: "
            "nothing written") in output


@pytest.mark.parametrize("expression, column, expected", [
    ("ttc_min_s < 2 and", 18, "expected a field name, 'not' or '('"),
    ("ttc_min_s < 2 and maneuver_class in (CINF, CINB", 48, "expected ',' or ')'"),
    ("ttc_min_s => 2", 11, "unexpected character '='"),
])
def test_a_malformed_expression_is_a_usage_error_naming_its_column(tmp_path, expression,
                                                                  column, expected):
    code, output, _ = mine(DATA, tmp_path / "out", "--where", expression)
    assert code == 2
    assert f"Invalid value for '--where': column {column}: {expected}" in output
    assert not (tmp_path / "out").exists()  # found before anything is written


def test_an_unknown_field_is_a_usage_error_listing_the_known_ones(tmp_path):
    code, output, _ = mine(DATA, tmp_path / "out", "--where", "ttc < 2")
    assert code == 2 and "unknown field 'ttc'; known: ttc_min_s, thw_min_s" in output


def test_run_makes_scenarios_of_the_matching_mined_records_only(everything, tmp_path):
    mined = tmp_path / "mined"
    assert mine(DATA, mined)[0] == 0
    braking = [r["scenario_id"] for r in everything if r["maneuver_class"] == "BR_BK"]
    expression = "brake_1s_max_ms2 >= 2 and maneuver_class == BR_BK"
    assert braking and all(parse_where(expression)(r) for r in everything
                           if r["scenario_id"] in braking)
    result = CliRunner().invoke(cli, ["run", str(mined), "--no-llm", "--no-replay", "--out",
                                      str(tmp_path / "runs"), "--run-id", "w",
                                      "--where", expression])
    assert result.exit_code == 0, result.output
    made = sorted(p.name for p in (tmp_path / "runs" / "w").iterdir() if p.is_dir())
    assert made == sorted(braking)
    selection = json.loads((tmp_path / "runs" / "w" / "run.json").read_text())["selection"]
    assert selection["where"] == expression


def test_run_with_a_filter_that_matches_nothing_makes_no_run_folder(tmp_path):
    mined = tmp_path / "mined"
    assert mine(DATA, mined)[0] == 0
    result = CliRunner().invoke(cli, ["run", str(mined), "--no-llm", "--no-replay", "--out",
                                      str(tmp_path / "runs"), "--run-id", "none",
                                      "--where", "lat_acc_peak_ms2 > 50"])
    assert result.exit_code == 1
    assert "--where 'lat_acc_peak_ms2 > 50' matched none of the" in result.output
    assert not (tmp_path / "runs" / "none").exists()
    bad = CliRunner().invoke(cli, ["run", str(mined), "--out", str(tmp_path / "runs"),
                                   "--where", "maneuver_class in CINF"])
    assert bad.exit_code == 2 and "column 19: expected '(' opening the list" in bad.output


def test_on_a_real_us101_snippet(tmp_path):
    """The filter on real NGSIM records: what it writes is what it matches among all."""
    shared = shared_data()
    snippet = shared / "ngsim" / "us101" / "USA_US101-9_1_T-1.xml" if shared else None
    if snippet is None or not snippet.is_file():
        pytest.skip("no shared NGSIM data here (../shared/data or $SCENWEAVE_SHARED_DATA)")
    expression = "thw_min_s < 1 and maneuver_class in (FLF, FLB, CINF, CINB)"
    code, output, every = mine(snippet, tmp_path / "all")
    assert code == 0, output
    expected = sorted(r["scenario_id"] for r in every if parse_where(expression)(r))
    assert 0 < len(expected) < len(every)
    code, output, records = mine(snippet, tmp_path / "some", "--where", expression)
    assert code == 0, output
    assert sorted(r["scenario_id"] for r in records) == expected
    assert all(r["criticality"]["thw_min_s"] < 1 for r in records)
    code, output, records = mine(snippet, tmp_path / "none", "--where", "ttc_min_s < 0")
    assert code == 1 and records == [] and "matched none of the" in output

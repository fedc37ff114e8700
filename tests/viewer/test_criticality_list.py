"""The viewer's list of scenarios made from mined records says how critical each event was
(issue 32 item 5): the numbers of the record's ``criticality``, in columns a click sorts, with
a bound per number that filters; checked in Chromium on the static export, as a user opens it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.viewer import catalog
from tests.mining.conftest import DATA

RUN = "critical"
#: the mined fixture records that closed in on someone: a handful of scenarios
WHERE = "ttc_min_s < 20"


@pytest.fixture(scope="module")
def mined_run(tmp_path_factory) -> tuple[Path, dict[str, dict]]:
    """A --no-llm run of the fixture data's mined records ``WHERE`` matches, and each
    record's criticality by scenario id."""
    root = tmp_path_factory.mktemp("critical")
    runner = CliRunner()
    mined = runner.invoke(cli, ["mine", str(DATA), "--out", str(root / "mined")])
    assert mined.exit_code == 0, mined.output
    made = runner.invoke(cli, ["run", str(root / "mined"), "--no-llm", "--no-replay",
                               "--out", str(root / "runs"), "--run-id", RUN, "--where", WHERE])
    assert made.exit_code == 0, made.output
    records = {r["scenario_id"]: r["criticality"]
               for path in (root / "mined").glob("*/*.json")
               for r in json.loads(path.read_text())}
    return root / "runs", records


def test_each_mined_scenario_row_carries_its_records_criticality(mined_run):
    runs, records = mined_run
    rows = catalog.run_list(catalog.find_runs([runs]))[0]["scenarios"]
    assert len(rows) >= 3
    for row in rows:
        assert row["criticality"] == records[row["id"]]
        assert row["criticality"]["ttc_min_s"] < 20


def rows_ttc(page) -> list[str]:
    return page.eval_on_selector_all(
        "tr.scenario td[data-field='ttc_min_s']", "cells => cells.map(c => c.textContent)")


@pytest.mark.slow
def test_the_list_shows_sorts_and_filters_by_criticality(page, mined_run, tmp_path, artifacts):
    from scenweave.viewer.static_site import write_static_site

    runs, records = mined_run
    write_static_site([runs], tmp_path / "site")
    page.goto((tmp_path / "site" / "index.html").as_uri())
    page.wait_for_selector("tr.scenario")
    heads = page.eval_on_selector_all("th.sortable", "hs => hs.map(h => h.dataset.sort)")
    assert heads == ["ttc_min_s", "thw_min_s", "brake_1s_max_ms2", "lat_acc_peak_ms2"]
    shown = {page.get_attribute(f"tr.scenario >> nth={i}", "data-key").split("/", 1)[1]: i
             for i in range(page.locator("tr.scenario").count())}
    assert set(shown) == {sid for sid, c in records.items()
                          if c["ttc_min_s"] is not None and c["ttc_min_s"] < 20}
    for sid in shown:
        cell = page.locator(f"tr[data-key='{RUN}/{sid}'] td[data-field='thw_min_s']")
        assert float(cell.inner_text()) == pytest.approx(records[sid]["thw_min_s"], abs=0.005)

    ascending = sorted(records[sid]["ttc_min_s"] for sid in shown)
    page.click("th[data-sort='ttc_min_s']")
    assert [float(v) for v in rows_ttc(page)] == pytest.approx(ascending, abs=0.005)
    page.click("th[data-sort='ttc_min_s']")
    assert [float(v) for v in rows_ttc(page)] == pytest.approx(ascending[::-1], abs=0.005)

    page.screenshot(path=str(artifacts / "criticality-list.png"), full_page=True)
    bound = ascending[len(ascending) // 2]
    page.fill("#crit-ttc_min_s", str(bound))
    kept = [float(v) for v in rows_ttc(page)]
    assert kept and all(v <= bound + 0.005 for v in kept)
    assert len(kept) == sum(1 for v in ascending if v <= bound)
    page.fill("#crit-brake_1s_max_ms2", "1000")
    assert page.locator("tr.scenario").count() == 0


def test_the_in_situ_batch_of_mine_lists_its_records_criticality(esmini, tmp_path, monkeypatch):
    """``mine --in-situ`` writes one in-situ folder per record (no recorded.json beside it):
    the list reads each one's criticality from the records it was made from."""
    pytest.importorskip("scenweave.mining.recorded_road")
    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path / "home"))
    out = tmp_path / "out"
    made = CliRunner().invoke(cli, ["mine", str(DATA / "commonroad_small.xml"), "--out",
                                    str(out), "--in-situ", "--context-s", "1"])
    assert (out / "in_situ").is_dir(), made.output
    records = {r["scenario_id"]: r["criticality"] for path in out.glob("*/*.json")
               if path.parent.name != "in_situ" for r in json.loads(path.read_text())}
    rows = catalog.run_list(catalog.find_runs([out / "in_situ"]))[0]["scenarios"]
    assert rows
    for row in rows:
        assert row["criticality"] == records[row["id"]]

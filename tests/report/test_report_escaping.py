"""A record's text in ``report.html`` and ``mining_report.html`` is shown, never run: the
pages are rendered from templates that escape every value, whatever a record holds."""

from __future__ import annotations

import json

import lxml.html
import pytest

from scenweave.presentation.bench_report import render_bench
from scenweave.presentation.metrics import metrics
from scenweave.presentation.mining_report import write_mining_report
from scenweave.presentation.report import write_run_report
from scenweave.run_folder import safe_name
from scenweave.schemas.scenario_folder import REPORT_FILE, RUN_FILE, STATUS_NAME, SUMMARY_FILE

SCRIPT_ID = "BRAKE_<script>alert('id')</script>"
SCRIPT_ERROR = "NameError: <script>alert(\"error\")</script> & more"
SCRIPT_FILE = "records/<script>alert('file')</script>.csv"


def _outcome(scenario_id: str, status: str, **more) -> dict:
    return {"scenario_id": scenario_id, "maneuver_class": "BRAKE", "status": status,
            "attempts": 1, "timings_s": {"total": 1.0}, **more}


@pytest.fixture
def run(tmp_path):
    """A run folder written by hand: one record whose id is a script, one whose error is, and
    a refused record whose file name and message are."""
    outcomes = [_outcome(SCRIPT_ID, "ok"),
                _outcome("BRAKE_2", "failed", error=SCRIPT_ERROR, error_taxonomy=["name"])]
    for outcome in outcomes:
        folder = tmp_path / safe_name(outcome["scenario_id"])
        folder.mkdir()
        (folder / STATUS_NAME).write_text(json.dumps(outcome))
    issue = {"file": SCRIPT_FILE, "row": 4, "field": "<b>speed</b>",
             "message": "<script>alert('message')</script>"}
    (tmp_path / RUN_FILE).write_text(json.dumps({"mode": "no-llm", "input": "<i>records</i>",
                                                 "scenarios": 3}))
    (tmp_path / SUMMARY_FILE).write_text(json.dumps({
        "run_id": "<script>run</script>", "scenarios": outcomes, "input_issues": [issue]}))
    return tmp_path


def _text(element) -> str:
    return " ".join(element.text_content().split())


def test_a_record_s_script_is_shown_as_text_in_the_run_report(run):
    html = write_run_report(run).read_text()
    assert "<script" not in html and "<b>" not in html and "<i>" not in html
    assert "&lt;script&gt;alert(&#39;id&#39;)&lt;/script&gt;" in html
    parsed = lxml.html.fromstring(html)
    assert not parsed.xpath("//script | //b | //i")
    assert parsed.xpath("//title")[0].text == "ScenWeave run <script>run</script>"
    [scenarios] = parsed.xpath("//h2[.='Scenarios']/following-sibling::table[1]")
    rows = {_text(tr[0]): tr for tr in scenarios.xpath(".//tbody/tr")}
    assert set(rows) == {SCRIPT_ID, "BRAKE_2"}
    assert _text(rows["BRAKE_2"][-1]) == SCRIPT_ERROR
    assert rows["BRAKE_2"][-1].xpath("./span/@class") == ["error"]
    # the links go to the folder of the safe name, the id never becomes part of an address
    hrefs = rows[SCRIPT_ID].xpath(".//a/@href")
    assert hrefs == [f"{safe_name(SCRIPT_ID)}/", f"{safe_name(SCRIPT_ID)}/{STATUS_NAME}"]
    [refused] = parsed.xpath("//h2[.='Refused records (input errors)']"
                             "/following-sibling::table[1]")
    assert [_text(td) for td in refused.xpath(".//tbody/tr/td")] == [
        SCRIPT_FILE, "4", "<b>speed</b>", "<script>alert('message')</script>"]


def test_the_report_file_is_the_rendered_page(run):
    path = write_run_report(run)
    assert path == run / REPORT_FILE
    html = path.read_text()
    assert html.startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    assert "{{" not in html and "{%" not in html
    assert "2 of 3 scenarios finished" in html


def test_a_recording_s_script_is_shown_as_text_in_the_mining_report(tmp_path):
    report = {"records_written": 1, "records_by_class": {"BRAKE": 1},
              "files": {SCRIPT_FILE: {"reader": "<script>r</script>", "tracks": 2,
                                      "vehicle_hours": 0.5, "events_by_class": {"BRAKE": 1}}},
              "vehicle_hours": 0.5, "seconds": 2.0,
              "skipped": [{"scenario_id": SCRIPT_ID, "field": None, "reason": SCRIPT_ERROR}],
              "duplicates": [], "warnings": ["<script>alert('warning')</script>"],
              "values": {"BRAKE": {"<script>p</script>": [1.0, 2.0, 4.0]}}}
    saved = tmp_path / "mining_report.json"
    saved.write_text(json.dumps(report))
    html = write_mining_report(saved).read_text()
    assert "<script" not in html
    parsed = lxml.html.fromstring(html)
    assert not parsed.xpath("//script")
    assert parsed.xpath("//li")[0].text == "<script>alert('warning')</script>"
    assert [_text(td) for td in parsed.xpath("//h2[.='Skipped']/following-sibling::table[1]"
                                             "//td")] == [SCRIPT_ID, "", SCRIPT_ERROR]
    [chart] = parsed.xpath("//svg")
    assert chart.get("aria-label") == "histogram of <script>p</script>"
    assert "900x real time" in html


def test_the_bench_page_escapes_its_name_models_and_errors():
    model, error = "<script>model</script>", "<script>error</script>"
    summary = {"models": {model: {"overall": metrics([]), "by_class": {}}},
               "latency_table": {"BRAKE": {model: None}}, "error_table": {error: {model: 2}}}
    html = render_bench("<script>bench</script>", summary, {})
    parsed = lxml.html.fromstring(html)
    assert not parsed.xpath("//script")
    assert parsed.xpath("//title")[0].text == "ScenWeave benchmark <script>bench</script>"
    assert parsed.xpath("//h1")[0].text == "Benchmark <script>bench</script>"
    cells = [td.text_content() for td in parsed.xpath("//td")]
    assert model in cells and error in cells and "–" in cells

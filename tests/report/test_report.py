"""``report.html`` of a real ``--no-llm`` run, read in headless Chromium as a user would."""

from __future__ import annotations

import json
from urllib.parse import urljoin

import lxml.html
import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.presentation.report import write_run_report
from scenweave.runner import run_batch
from scenweave.schemas.scenario_folder import REPORT_FILE
from tests.report.chromium import dump_dom, screenshot


@pytest.fixture(scope="module")
def run(sample_raw, tmp_path_factory):
    out = tmp_path_factory.mktemp("runs")
    result = run_batch(sample_raw, out, InputSelection(classes=("BRAKE", "LCF", "U4_1"),
                                                       per_class=2),
                       PipelineSettings(no_llm=True), run_id="seen")
    return result.folder.root


@pytest.fixture(scope="module")
def page(run, tmp_path_factory):
    """The report as Chromium rendered it, parsed."""
    dom = dump_dom((run / REPORT_FILE).as_uri(), tmp_path_factory.mktemp("chromium"))
    return lxml.html.fromstring(dom)


def _text(element) -> str:
    return " ".join(element.text_content().split())


def test_the_reader_sees_the_counts_of_the_run(run, page):
    summary = json.loads((run / "summary.json").read_text())
    boxes = {_text(box).split()[1]: int(_text(box).split()[0])
             for box in page.xpath("//div[contains(concat(' ', @class, ' '), ' count ')]")}
    assert boxes["scenarios"] == summary["total"] == 6
    for status, count in summary["counts"].items():
        assert boxes[status] == count


def test_the_reader_sees_a_row_per_class(run, page):
    summary = json.loads((run / "summary.json").read_text())
    per_class = page.xpath("//table")[0]
    rows = {(_text(tr[0])): [_text(td) for td in tr] for tr in per_class.xpath(".//tbody/tr")}
    assert set(rows) == {"BRAKE", "LCF", "U4_1", "all"}
    header = [_text(th) for th in per_class.xpath(".//thead//th")]
    brake = dict(zip(header, rows["BRAKE"], strict=True))
    assert brake["n"] == "2"
    assert brake["failed"] == str(summary["by_class"]["BRAKE"]["failed"])
    assert brake["ok"] == str(summary["by_class"]["BRAKE"]["ok"])


def test_the_figures_are_drawn_inline(page):
    images = page.xpath("//figure/img")
    assert len(images) == 3
    assert all(img.get("src").startswith("data:image/svg+xml;base64,") for img in images)


def test_a_scenario_link_opens_that_scenario_s_trace(run, page, tmp_path):
    links = [a.get("href") for a in page.xpath("//a") if a.get("href").endswith("trace.jsonl")]
    assert len(links) == 6
    target = urljoin((run / REPORT_FILE).as_uri(), links[0])
    shown = lxml.html.fromstring(dump_dom(target, tmp_path / "profile"))
    [shown_text] = shown.xpath("//pre")  # Chromium shows a text file in one <pre>
    first_event = json.loads(shown_text.text_content().splitlines()[0])
    assert first_event["node"] == "spawn"


def test_the_page_is_drawn(run, tmp_path):
    png = screenshot((run / REPORT_FILE).as_uri(), tmp_path / "profile", tmp_path / "report.png")
    data = png.read_bytes()
    assert data.startswith(b"\x89PNG") and len(data) > 20_000  # a page with figures, not blank


def test_error_text_is_shown_not_run_as_markup(run, tmp_path):
    copy = tmp_path / "run"
    copy.mkdir()
    summary = json.loads((run / "summary.json").read_text())
    summary["scenarios"][0]["error"] = "<script>document.title='owned'</script>"
    (copy / "summary.json").write_text(json.dumps(summary))
    html = write_run_report(copy).read_text()
    assert "<script>document" not in html and "&lt;script&gt;" in html


def test_cli_report_rewrites_the_report_of_a_run_folder(run):
    (run / REPORT_FILE).unlink()
    result = CliRunner().invoke(cli, ["report", str(run)])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("report of run seen: 6 scenarios")
    assert (run / REPORT_FILE).exists()

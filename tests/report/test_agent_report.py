"""``report.html`` of an agent run with every outcome — ok, repaired, fallback and a poisoned
record that fails — read in headless Chromium: what a reader sees, not what the HTML says.

The LLM is replayed (whole-script strategy: the right reply is each record's worked example
with its values written in), the scripts run in the real bubblewrap sandbox and are validated
for real."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from urllib.parse import urlparse
from urllib.request import url2pathname

import lxml.html
import pytest

from scenweave.agent import AgentSettings
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.run_folder import safe_name
from scenweave.runner import run_batch
from scenweave.sandbox import SandboxSettings
from scenweave.schemas.scenario_folder import REPORT_FILE
from tests.replies import right_replies
from tests.report.chromium import dump_dom, probe
from tests.worker.records import BRAKE, LCF, POISONED, ingest_with_poisoned_record

#: not a script at all (taxonomy syntax)
NO_CODE = "I cannot help with that."
#: a script that raises NameError when run
NAME_ERROR = ("```python\nfrom pathlib import Path\n\n\ndef generate(params, out_path):\n"
              "    undefined_helper()\n```\n")


@pytest.fixture(scope="module")
def run(sample_raw, tmp_path_factory) -> tuple[Path, dict[str, str]]:
    """The run folder and the status each scenario must end with (derived from the replies)."""
    if shutil.which("bwrap") is None:
        pytest.skip("AGENT REPORT NOT TESTED: bubblewrap is not installed")
    tmp = tmp_path_factory.mktemp("agent-report")
    records = ingest_with_poisoned_record(sample_raw, tmp / "records")
    urban = json.loads((records / "urban" / "U4_1.json").read_text())
    u4_1 = [record["scenario_id"] for record in urban]
    selection = InputSelection(classes=("BRAKE", "LCF", "U4_1"), per_class=2)
    right = right_replies(records, selection)
    replies = tmp / "replies.json"
    replies.write_text(json.dumps({**{sid: [reply] for sid, reply in right.items()},
                                   LCF[0]: [NO_CODE, right[LCF[0]]],
                                   u4_1[0]: [NO_CODE, NAME_ERROR, NO_CODE],
                                   POISONED: [NAME_ERROR] * 3}))
    agent = AgentSettings(llm="replay", replay_file=replies, repair="error-feedback",
                          sandbox=SandboxSettings(backend="bwrap", wall_time_s=30))
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SCENWEAVE_HOME", str(tmp / "home"))
        result = run_batch(records, tmp / "runs", selection,
                           PipelineSettings(no_llm=False, agent=agent), run_id="mixed")
    expected = {BRAKE[0]: "ok", POISONED: "failed", LCF[0]: "repaired", LCF[1]: "ok",
                u4_1[0]: "fallback", u4_1[1]: "ok"}
    return result.folder.root, expected


@pytest.fixture(scope="module")
def page(run, tmp_path_factory):
    root, _ = run
    return lxml.html.fromstring(dump_dom((root / REPORT_FILE).as_uri(),
                                         tmp_path_factory.mktemp("chromium")))


@pytest.fixture(scope="module")
def seen(run, tmp_path_factory) -> dict:
    root, _ = run
    return probe((root / REPORT_FILE).as_uri(), tmp_path_factory.mktemp("probe") / "profile")


def _text(element) -> str:
    return " ".join(element.text_content().split())


def _table_after(page, heading: str):
    [table] = page.xpath(f"//h2[normalize-space()='{heading}']/following-sibling::table[1]")
    header = [_text(th) for th in table.xpath(".//thead//th")]
    return [dict(zip(header, (_text(td) for td in tr.xpath("./td")), strict=True))
            for tr in table.xpath(".//tbody/tr")]


def test_the_run_ended_as_the_replies_say(run):
    root, expected = run
    summary = json.loads((root / "summary.json").read_text())
    assert {o["scenario_id"]: o["status"] for o in summary["scenarios"]} == expected


def test_the_reader_sees_one_count_per_outcome(page):
    boxes = {_text(box).split()[1]: int(_text(box).split()[0])
             for box in page.xpath("//div[contains(concat(' ', @class, ' '), ' count ')]")}
    assert boxes == {"scenarios": 6, "ok": 3, "repaired": 1, "fallback": 1, "failed": 1}


def test_the_reader_sees_the_error_taxonomy(page):
    rows = {row["error"]: row["count"] for row in _table_after(page, "Error taxonomy")}
    # LCF 0: no code; U4_1 0: no code, NameError, no code; the poisoned record: spawn
    assert rows == {"name": "1", "spawn": "1", "syntax": "3"}


def test_the_per_class_table_shows_the_outcomes_and_first_attempts(page):
    rows = {row[""]: row for row in _table_after(page, "Per class")}
    assert (rows["LCF"]["ok"], rows["LCF"]["repaired"], rows["LCF"]["1st attempt"]) == (
        "1", "1", "50%")
    assert (rows["U4_1"]["fallback"], rows["U4_1"]["SR"], rows["U4_1"]["delivered"]) == (
        "1", "50%", "100%")
    assert (rows["BRAKE"]["failed"], rows["all"]["SR"], rows["all"]["delivered"]) == (
        "1", "67%", "83%")


def test_the_error_column_says_what_went_wrong(run, page):
    _, expected = run
    rows = {row["scenario"]: row for row in _table_after(page, "Scenarios")}
    assert {sid: row["status"] for sid, row in rows.items()} == expected
    assert "NoSpawnFits" in rows[POISONED]["error"]
    fallback = next(sid for sid, status in expected.items() if status == "fallback")
    assert rows[fallback]["error"].startswith("EmptyCode:")  # the last failed attempt
    assert rows[fallback]["attempts"] == "3"
    assert rows[LCF[0]]["error"].startswith("EmptyCode:")
    assert all(rows[sid]["error"] == "" for sid, status in expected.items() if status == "ok")


def test_every_figure_decodes(seen):
    images = seen["images"]
    assert [i["alt"] for i in images] == ["latency per class", "latency boxplot",
                                          "cumulative scenarios"]
    assert all(i["complete"] and i["naturalWidth"] > 100 for i in images), images


def test_every_trace_link_resolves_to_that_scenario_s_trace(run, seen):
    root, expected = run
    traces = [link["href"] for link in seen["links"] if link["text"] == "trace.jsonl"]
    assert len(traces) == len(expected)
    for href in traces:
        path = Path(url2pathname(urlparse(href).path))
        assert path.parent.parent == root and path.is_file(), href
        nodes = [json.loads(line)["node"] for line in path.read_text().splitlines()]
        status = json.loads((path.parent / "status.json").read_text())
        assert path.parent.name == safe_name(status["scenario_id"])
        # the poisoned record never got a spawn point; the others end where their status says
        assert (nodes[0], nodes[-1]) == {
            "ok": ("spawn", "validate"), "repaired": ("spawn", "validate"),
            "fallback": ("spawn", "fallback"), "failed": ("error", "error"),
        }[expected[status["scenario_id"]]]


def test_the_failed_scenario_s_trace_opens_in_the_browser(run, seen, tmp_path):
    root, _ = run
    [href] = [link["href"] for link in seen["links"]
              if link["text"] == "trace.jsonl" and safe_name(POISONED) in link["href"]]
    shown = lxml.html.fromstring(dump_dom(href, tmp_path / "profile"))
    [text] = shown.xpath("//pre")
    [event] = [json.loads(line) for line in text.text_content().splitlines()]
    assert event["node"] == "error" and "NoSpawnFits" in event["error"]

"""Replay pictures (``presentation.replay_figures``) and the replay part of a run's
``report.html``.

A tiny ``--no-llm`` run is played in the real esmini; one of its scenarios is then made a
failed replay by hand (a collision written into its ``replay.json`` and ``status.json``), as
if esmini had seen one, so the report must count it and show its picture whatever the sample
scenarios do in esmini.
"""

from __future__ import annotations

import base64
import json
import shutil
from pathlib import Path

import lxml.html
import pytest
from lxml import etree

from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.player import Playback, PlayerUnavailable, ReplaySettings, find_esmini
from scenweave.presentation.replay_facts import FAIL_COLOUR
from scenweave.presentation.replay_figures import (
    FIGURE_PX,
    draw_replay_figure,
    figure_source,
    is_current,
)
from scenweave.presentation.report import pct, replay_figure_picks, replay_rate, write_run_report
from scenweave.run_folder import RunFolder
from scenweave.runner import run_batch, summarize
from scenweave.schemas.scenario_folder import (
    FIGURE_NAME,
    REPORT_FILE,
    SUMMARY_FILE,
    VERDICT_NAME,
)

CLASSES = ("FLF", "LCF", "U4_2")
#: the scenario made to fail (one with an NPC to collide with) and a clean one to compare
CRASHED_CLASS = "FLF"
SVG = "{http://www.w3.org/2000/svg}"


@pytest.fixture(scope="module")
def run(sample_raw, tmp_path_factory) -> Path:
    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(f"REPLAY FIGURES NOT TESTED: no esmini here ({err})")
    out = tmp_path_factory.mktemp("replay-runs")
    result = run_batch(sample_raw, out, InputSelection(classes=CLASSES, per_class=1),
                       PipelineSettings(no_llm=True, replay=ReplaySettings()), run_id="replayed")
    assert result.summary["replay"]["played"] == len(CLASSES)
    return result.folder.root


@pytest.fixture(scope="module")
def crashed(run) -> Path:
    """The LCF scenario, its replay now ending in a collision of the ego and the NPC at 3 s;
    the summary and the report rewritten from the folders (as ``scenweave report`` would)."""
    [folder] = [p for p in run.iterdir() if p.name.startswith(CRASHED_CLASS)]
    playback = Playback.read(folder / "replay.json")
    playback.collisions = [(3.0, "hero", "npc"), (3.05, "hero", "npc")]
    playback.write(folder / "replay.json")
    status = json.loads((folder / "status.json").read_text())
    status["replay"] = {**status["replay"], "passed": False, "codes": ["REPLAY_COLLISION"]}
    status["validation"]["errors"] = [{"code": "REPLAY_COLLISION", "severity": "error",
                                       "message": "at 3.00 s: hero and npc collide; the record "
                                                  "has no collision", "line": None}]
    status["status"], status["error"] = "failed", "REPLAY_COLLISION"
    (folder / "status.json").write_text(json.dumps(status))
    verdict = json.loads((folder / VERDICT_NAME).read_text())  # what the figure draws
    verdict.update(passed=False, codes=["REPLAY_COLLISION"], findings=[
        {"code": "REPLAY_COLLISION", "t": 3.0, "message": status["validation"]["errors"][0][
            "message"]}])
    (folder / VERDICT_NAME).write_text(json.dumps(verdict))
    (folder / FIGURE_NAME).unlink(missing_ok=True)
    run_folder = RunFolder(run)
    run_folder.write(SUMMARY_FILE, summarize(run_folder, []))
    write_run_report(run)
    return folder


@pytest.fixture(scope="module")
def page(crashed):
    return lxml.html.parse(str(crashed.parent / REPORT_FILE)).getroot()


def _outcomes(run: Path) -> list[dict]:
    return [json.loads((p / "status.json").read_text()) for p in sorted(run.iterdir())
            if (p / "status.json").exists()]


def _svg(path: Path) -> etree._Element:
    """The figure parsed as XML (it must be well-formed)."""
    return etree.parse(str(path)).getroot()


def _texts(element: etree._Element) -> list[str]:
    return ["".join(t.itertext()) for t in element.iter(f"{SVG}text")]


def _red(element: etree._Element) -> list[etree._Element]:
    """The elements drawn or written in the figures' red."""
    return [e for e in element.iter() if FAIL_COLOUR in (e.get("fill"), e.get("stroke"))]


def _map(root: etree._Element) -> etree._Element:
    [panel] = root.findall(f"{SVG}g[@id='map']")
    return panel


def test_every_played_scenario_gets_a_figure_of_the_stated_size(run, crashed):
    for folder in sorted(p for p in run.iterdir() if (p / "replay.json").exists()):
        path = draw_replay_figure(folder)
        assert path == folder / FIGURE_NAME
        root = _svg(path)
        assert root.tag == f"{SVG}svg"
        assert (root.get("width"), root.get("height")) == tuple(map(str, FIGURE_PX)), folder.name
        assert root.get("viewBox") == f"0 0 {FIGURE_PX[0]} {FIGURE_PX[1]}"
        playback = Playback.read(folder / "replay.json")
        drawn = {g.get("data-actor"): g for g in _map(root).iter(f"{SVG}g")
                 if g.get("class") == "actor"}
        assert set(drawn) == set(playback.entities), folder.name  # every path, named
        assert all(len(g.find(f"{SVG}path").get("d")) > 100 for g in drawn.values())
        assert set(playback.entities) <= set(_texts(root))  # the speed legend names them
        assert {g.get("id") for g in root.findall(f"{SVG}g")} == {"speed", "lower", "map"}
        assert path.stat().st_size < 150_000
        assert is_current(folder, json.loads((folder / "status.json").read_text()))


def test_the_collision_is_marked_on_the_map_in_red(run, crashed):
    root = _svg(draw_replay_figure(crashed))
    [mark] = [p for p in _map(root).iter(f"{SVG}path") if p.get("class") == "collision"]
    assert mark.get("fill") == FAIL_COLOUR
    assert "hero–npc 3.00 s" in _texts(_map(root))  # the X and its time
    assert [t for t in _texts(root) if t.startswith("REPLAY_COLLISION at 3.00 s")]
    [other] = [p for p in run.iterdir() if p.name.startswith("LCF")]
    playback = Playback.read(other / "replay.json")
    assert not playback.collisions  # a clean replay: its map has nothing red
    assert _red(_map(_svg(draw_replay_figure(other)))) == []


def test_no_replay_no_figure_and_an_engine_error_gets_one(tmp_path):
    assert draw_replay_figure(tmp_path) is None
    assert not (tmp_path / FIGURE_NAME).exists()
    Playback(engine_error="esmini aborted (signal 11)", log=["loading", "Segfault"]).write(
        tmp_path / "replay.json")
    (tmp_path / "status.json").write_text(json.dumps(
        {"scenario_id": "X", "maneuver_class": "BRAKE",
         "replay": {"played": False, "passed": False, "codes": ["REPLAY_ENGINE"]}}))
    root = _svg(draw_replay_figure(tmp_path))
    assert (root.get("width"), root.get("height")) == tuple(map(str, FIGURE_PX))
    said = {"".join(t.itertext()) for t in _red(root)}  # the failed verdict and esmini's error
    assert {"X · BRAKE · replay FAILED: REPLAY_ENGINE", "esmini could not play the scenario",
            "esmini aborted (signal 11)", "Segfault"} <= said


def test_a_record_s_text_is_shown_in_the_figure_never_run(run, tmp_path):
    """A scenario id and a finding message with markup are text in the SVG, escaped: no
    element of theirs, and the figure still parses and names what it shows."""
    [source] = [p for p in run.iterdir() if p.name.startswith("LCF")]
    folder = tmp_path / "odd"
    shutil.copytree(source, folder)
    odd_id = 'LCF <script>alert("x")</script> & <b>'
    params = json.loads((folder / "params.json").read_text())
    (folder / "params.json").write_text(json.dumps({**params, "scenario_id": odd_id}))
    status = json.loads((folder / "status.json").read_text())
    status["replay"] = {**status["replay"], "passed": False, "codes": ["REPLAY_SPEED"]}
    status["validation"]["errors"] = [{"code": "REPLAY_SPEED", "severity": "error",
                                       "message": "<script>document.x</script> & more"}]
    (folder / "status.json").write_text(json.dumps(status))
    verdict = json.loads((folder / VERDICT_NAME).read_text())
    verdict["findings"] = [{"code": "REPLAY_SPEED", "t": None,
                            "message": "<script>document.x</script> & more"}]
    (folder / VERDICT_NAME).write_text(json.dumps(verdict))
    path = draw_replay_figure(folder)
    root = _svg(path)
    assert not [e for e in root.iter() if etree.QName(e).localname in ("script", "b")]
    assert root.find(f"{SVG}title").text.startswith(odd_id)
    assert "REPLAY_SPEED <script>document.x</script> & more" in _texts(root)
    raw = path.read_text()
    assert "<script" not in raw and "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt; &amp;" in raw
    assert is_current(folder, status)
    status["replay"]["codes"] = ["REPLAY_GAP"]  # another verdict: the figure is stale
    assert not is_current(folder, status)
    assert figure_source(folder, status) not in raw


def test_the_per_class_table_has_the_replay_pass_rate(crashed, page):
    outcomes = _outcomes(crashed.parent)
    per_class = page.xpath("//table")[0]
    header = [th.text_content().strip() for th in per_class.xpath(".//thead//th")]
    assert header[-1] == "replay"
    rows = {tr[0].text_content(): tr[-1].text_content() for tr in per_class.xpath(".//tbody/tr")}
    assert set(rows) == {*CLASSES, "all"}
    for code in CLASSES:
        replays = [o["replay"] for o in outcomes if o["maneuver_class"] == code]
        passed = sum(r["passed"] for r in replays)
        assert rows[code] == f"{passed}/1 ({pct(float(passed))})"
    assert rows[CRASHED_CLASS] == "0/1 (0%)"
    passed = sum(o["replay"]["passed"] for o in outcomes)
    assert rows["all"] == f"{passed}/3 ({pct(passed / 3)})" == replay_rate(outcomes)


def test_the_replay_codes_are_counted(crashed, page):
    outcomes = _outcomes(crashed.parent)
    [codes] = [t for t in page.xpath("//table")
               if t.xpath(".//th")[0].text_content() == "replay finding"]
    counted = {tr[0].text_content(): int(tr[1].text_content()) for tr in codes.xpath(".//tbody/tr")}
    expected: dict[str, int] = {}
    for o in outcomes:
        for code in o["replay"]["codes"]:
            expected[code] = expected.get(code, 0) + 1
    assert counted == expected and counted["REPLAY_COLLISION"] >= 1


def test_the_failed_replay_s_figure_is_drawn_and_embedded(crashed, page):
    assert (crashed / FIGURE_NAME).exists()  # drawn by the report: the fixture deleted it
    captions = {f.xpath("./figcaption")[0].text_content(): f.xpath("./img")[0].get("src")
                for f in page.xpath("//figure")}
    [src] = [src for caption, src in captions.items()
             if caption.startswith(crashed.name) and "REPLAY_COLLISION" in caption]
    assert src.startswith("data:image/svg+xml;base64,")
    svg = base64.b64decode(src.removeprefix("data:image/svg+xml;base64,"))
    assert svg == (crashed / FIGURE_NAME).read_bytes()
    # every replay of this tiny run is shown: the failed one and the passing ones (<= 2 a class)
    replay_captions = [c for c in captions if ": replay " in c]
    assert len(replay_captions) == len(CLASSES)
    assert replay_captions[0].startswith(crashed.name)  # failures first


def test_the_scenario_links_include_the_replay_files(crashed, page):
    links = {a.get("href") for a in page.xpath("//a")}
    assert {f"{crashed.name}/replay.json", f"{crashed.name}/{FIGURE_NAME}"} <= links


def test_the_report_draws_the_missing_pictures_of_the_replays_it_shows(crashed, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(crashed.parent, copy)
    for svg in copy.glob(f"*/{FIGURE_NAME}"):
        svg.unlink()
    write_run_report(copy)
    drawn = {p.parent.name for p in copy.glob(f"*/{FIGURE_NAME}")}
    shown = {o["scenario_id"] for o in replay_figure_picks(_outcomes(copy))}
    assert drawn == shown == {p.name for p in copy.iterdir() if (p / "replay.json").exists()}


def test_the_picks_are_every_failure_and_two_passing_per_class_within_the_cap():
    def outcome(i: int, code: str, passed: bool) -> dict:
        return {"scenario_id": f"{code}_{i}", "maneuver_class": code,
                "replay": {"played": True, "passed": passed, "codes": [] if passed else ["X"]}}

    replayed = [outcome(i, code, i % 3 == 0) for code in ("A", "B") for i in range(9)]
    picks = replay_figure_picks(replayed, passing_per_class=2)
    assert [o["replay"]["passed"] for o in picks] == [False] * 12 + [True] * 4
    assert {o["scenario_id"] for o in picks if o["replay"]["passed"]} == {
        "A_0", "A_3", "B_0", "B_3"}
    capped = replay_figure_picks(replayed, limit=5)
    assert len(capped) == 5 and not any(o["replay"]["passed"] for o in capped)
    assert {o["maneuver_class"] for o in capped} == {"A", "B"}  # classes take turns

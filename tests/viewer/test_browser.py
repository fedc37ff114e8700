"""``scenweave view`` in a real browser: Debian's Chromium driven by Playwright, against the
viewer served on loopback (and its static export opened from disk, offline).

What a person would check by looking: every scenario is listed, the cars move on the map as
the replay says, the speed chart holds the replay's series and the record's values, the
judge's finding sits at its time, the trace shows each attempt. Screenshots are kept in
``build/test-artifacts/viewer/``."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest
from lxml import etree

from scenweave.judge.replay import judge_replay
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.player import Playback
from tests.viewer.runs import CUT_IN, EDITED, RUN_ID

pytestmark = pytest.mark.slow


def open_scenario(page, base: str, key: str) -> None:
    page.goto(f"{base}#/s/{key}")
    page.wait_for_function("window.viewer && window.viewer.page === 'scenario' "
                           "&& window.viewer.clock !== undefined", timeout=30_000)


def canvas_png(page, artifacts: Path, name: str) -> Path:
    path = artifacts / name
    page.locator("#scene").screenshot(path=str(path))
    return path


def differing_pixels(a: Path, b: Path) -> int:
    import numpy as np
    from PIL import Image

    first = np.asarray(Image.open(a).convert("RGB"), dtype=int)
    second = np.asarray(Image.open(b).convert("RGB"), dtype=int)
    return int((np.abs(first - second).sum(axis=2) > 30).sum())


def test_the_run_list_shows_every_scenario_and_filters(page, server, viewer_runs, artifacts):
    page.goto(server)
    page.wait_for_selector("tr.scenario")
    folders = sorted(p.name for p in viewer_runs["run"].iterdir() if (p / "status.json").is_file())
    keys = page.eval_on_selector_all("tr.scenario", "rows => rows.map(r => r.dataset.key)")
    assert sorted(keys) == sorted([f"{RUN_ID}/{name}" for name in folders]
                                  + [f"{EDITED}/{EDITED}"])
    cut_in = page.locator(f"tr[data-key='{RUN_ID}/{CUT_IN}']")
    assert "repaired" in cut_in.inner_text() and "passed" in cut_in.inner_text()
    page.screenshot(path=str(artifacts / "run-list.png"), full_page=True)
    page.fill("#search", "U4_1")
    assert page.locator("tr.scenario").count() == 1
    page.fill("#search", "")
    page.select_option("#status-filter", "repaired")
    assert page.eval_on_selector_all("tr.scenario", "rows => rows.map(r => r.dataset.key)") \
        == [f"{RUN_ID}/{CUT_IN}"]


def test_vehicles_move_on_the_canvas_as_the_replay_says(page, server, viewer_runs, artifacts):
    open_scenario(page, server, f"{RUN_ID}/{CUT_IN}")
    page.select_option("#camera", "whole")
    before = page.evaluate("window.viewer.player.actorPixels()")
    first = canvas_png(page, artifacts, "cut-in-start.png")
    page.select_option("#rate", "4")
    page.click("#play")
    page.wait_for_function("window.viewer.clock.t > 4", timeout=20_000)
    page.click("#play")  # pause
    t = page.evaluate("window.viewer.clock.t")
    after = page.evaluate("window.viewer.player.actorPixels()")
    scale = page.evaluate("window.viewer.player.view().scale")
    second = canvas_png(page, artifacts, "cut-in-playing.png")
    assert differing_pixels(first, second) > 200
    playback = Playback.read(viewer_runs["run"] / CUT_IN / "replay.json")
    for name in ("hero", "npc"):
        track = playback.tracks[name]
        metres = math.hypot(playback.value(name, "x", t) - track["x"][0],
                            playback.value(name, "y", t) - track["y"][0])
        moved_px = math.dist(before[name], after[name])
        assert metres > 50  # both drive ~36 m/s
        assert moved_px / scale == pytest.approx(metres, rel=0.03, abs=0.5), name


def test_the_speed_chart_holds_the_replayed_series_and_the_record(page, server, viewer_runs):
    open_scenario(page, server, f"{RUN_ID}/{CUT_IN}")
    chart = page.evaluate("(() => { const c = window.viewer.charts.speed; "
                          "return {data: c.plot.data, labels: c.labels, marks: c.marks}; })()")
    playback = Playback.read(viewer_runs["run"] / CUT_IN / "replay.json")
    assert chart["data"][0] == playback.times
    for name in playback.entities:
        assert chart["data"][1 + chart["labels"].index(name)] == playback.tracks[name]["speed"]
    params = json.loads((viewer_runs["run"] / CUT_IN / "params.json").read_text())
    starts = {m["entity"]: m["value"] for m in chart["marks"] if m["what"] == "start speed"}
    assert starts == {"hero": params["ego_speed_ms"], "npc": params["npc_speed_ms"]}
    gap = page.evaluate("window.viewer.charts.gap.marks")
    assert [(m["entity"], m["t"], m["value"]) for m in gap] == \
        [("npc", params["maneuver_start_s"], params["npc_distance_m"])]


def test_a_replay_finding_appears_at_its_time(page, server, viewer_runs, artifacts):
    folder = viewer_runs["edited"]
    params = json.loads((folder / "params.json").read_text())
    doc = ScenarioDoc(etree.parse(str(folder / "scenario.xosc")), params["map"])
    playback = Playback.read(folder / "replay.json")
    judged = [f for f in judge_replay(playback, params, doc) if f.code == "REPLAY_SPEED"]
    assert judged, "the edited cut-in should fail REPLAY_SPEED"
    when = judged[0].time_s  # the verdict's time, not one parsed from the message
    open_scenario(page, server, f"{EDITED}/{EDITED}")
    item = page.locator("#findings li[data-code='REPLAY_SPEED']")
    assert float(item.get_attribute("data-t")) == pytest.approx(when)
    assert "REPLAY_SPEED" in page.evaluate(
        "window.viewer.charts.speed.findings.map(f => f.code)")
    item.click()
    assert page.evaluate("window.viewer.clock.t") == pytest.approx(when)
    assert "active" in item.get_attribute("class")
    page.screenshot(path=str(artifacts / "finding-at-its-time.png"), full_page=True)


def test_the_trace_shows_each_attempt(page, server, viewer_runs, artifacts):
    status = json.loads((viewer_runs["run"] / CUT_IN / "status.json").read_text())
    assert status["attempts"] == 2
    open_scenario(page, server, f"{RUN_ID}/{CUT_IN}")
    page.click("#tab-trace")
    attempts = page.locator("section.attempt")
    assert attempts.count() == status["attempts"]
    assert "failed" in attempts.nth(0).locator("h3").inner_text()
    assert "EmptyCode" in attempts.nth(0).inner_text()  # the sandbox result, opened
    second = attempts.nth(1)
    assert "valid" in second.locator("h3").inner_text()
    assert "replay passed" in second.locator("h3").inner_text()
    second.locator("summary", has_text="diff to the worked example").click()
    assert second.locator("pre.diff .add").count() > 0
    page.screenshot(path=str(artifacts / "trace.png"), full_page=True)


def test_the_static_export_plays_offline_from_disk(page, viewer_runs, tmp_path, artifacts):
    from scenweave.viewer.static_site import write_static_site

    counts = write_static_site([viewer_runs["runs"], viewer_runs["hand"]], tmp_path / "site")
    assert counts["scenarios"] == 3
    asked = []
    page.route("**/*", lambda route: (asked.append(route.request.url), route.continue_()
                                      if route.request.url.startswith("file://")
                                      else route.abort()))
    page.goto((tmp_path / "site" / "index.html").as_uri())
    page.wait_for_selector("tr.scenario")
    page.click(f"tr[data-key='{RUN_ID}/{CUT_IN}']")
    page.wait_for_function("window.viewer.page === 'scenario' && window.viewer.clock")
    page.click("#play")
    page.wait_for_function("window.viewer.clock.t > 0.5", timeout=20_000)
    assert [url for url in asked if not url.startswith("file://")] == []
    page.click("#tab-files")
    page.click("a[data-file='params.json']")
    assert json.loads(page.inner_text("#file-view"))["scenario_id"] == CUT_IN
    page.screenshot(path=str(artifacts / "static-export.png"), full_page=True)


def test_the_variants_of_a_record_play_side_by_side(page, viewer_runs, tmp_path, artifacts):
    """A record with two variants as ``run --vary`` lays them out (``variants/vNN/`` with
    ``variant.json``): the hand-edited cut-in, kept, and one the agent could not ask for."""
    from scenweave.viewer.static_site import write_static_site

    run = tmp_path / "runs" / RUN_ID
    shutil.copytree(viewer_runs["run"], run)
    variants = run / CUT_IN / "variants"
    shutil.copytree(viewer_runs["edited"], variants / "v01")
    (variants / "v01" / "variant.json").write_text(json.dumps(
        {"id": "v01", "aspect": "vehicles", "kept": True, "changed": ["npc_speed_change"],
         "asked": {}, "errors": []}))
    (variants / "v02").mkdir()
    (variants / "v02" / "variant.json").write_text(json.dumps(
        {"id": "v02", "aspect": "lane", "kept": False, "changed": [], "asked": {},
         "errors": ["VARY_NO_LANE: no lane beside"]}))
    write_static_site([tmp_path / "runs"], tmp_path / "site")
    page.goto((tmp_path / "site" / "index.html").as_uri())
    page.wait_for_selector("tr.scenario")
    assert page.locator(f"tr[data-key='{RUN_ID}/{CUT_IN}'] td").last.inner_text() == "2"
    page.click(f"tr[data-key='{RUN_ID}/{CUT_IN}']")
    page.wait_for_function("window.viewer.page === 'scenario' && window.viewer.clock")
    page.click("#tab-variants")
    page.wait_for_function("document.querySelectorAll('#variants .stage').length === 3")
    cards = page.locator("#variants .stage")
    assert "kept · vehicles · changed: npc_speed_change" in cards.nth(1).inner_text()
    assert "not kept · lane · VARY_NO_LANE" in cards.nth(2).inner_text()
    assert cards.nth(2).locator("p.note").inner_text() == "not played: no replay.json in the folder"
    page.click("#play-variants")
    page.wait_for_function("window.viewer.clock.t > 1", timeout=20_000)
    page.screenshot(path=str(artifacts / "variants.png"), full_page=True)

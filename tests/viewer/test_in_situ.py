"""``scenweave view`` of a mined event in situ: the event on its converted road with every
recorded vehicle, animated from its replay, each car shown only while it is recorded, and the
in-situ judge's numbers beside it; in the server's JSON, in Debian's Chromium (Playwright)
and in the static export."""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.viewer import catalog
from tests.viewer.in_situ_run import RUN_ID, SCENARIO, VEHICLES

pytestmark = pytest.mark.slow
KEY = f"{RUN_ID}/{SCENARIO}/in_situ"
#: the fixture's vehicles: name -> (first, last recorded time)
SPANS = {("hero" if v[0] == "1" else f"v{v[0]}"): (v[1], v[2]) for v in VEHICLES}


@pytest.fixture(scope="module")
def runs(in_situ_scene: Path) -> dict[str, catalog.Run]:
    return catalog.find_runs([in_situ_scene.parent.parent])


def test_the_run_list_names_the_in_situ_scene_with_its_judge_numbers(runs):
    (row,) = catalog.run_list(runs)[0]["scenarios"]
    assert row["id"] == SCENARIO and row["in_situ"]["key"] == KEY
    assert row["in_situ"]["vehicles"] == len(VEHICLES)
    assert row["in_situ"]["passed"] is True and row["in_situ"]["share"] == 1.0
    assert row["in_situ"]["worst_m"] < 0.1


def test_the_in_situ_scene_has_every_vehicle_the_road_and_the_light(runs, in_situ_scene):
    detail = catalog.scenario_detail(runs, KEY)
    scene = detail["scene"]
    assert scene["played"] and scene["map"] == "road.xodr"
    assert {n: tuple(round(t, 3) for t in a["span"]) for n, a in scene["actors"].items()} \
        == SPANS
    replay = json.loads((in_situ_scene / "in_situ" / "replay.json").read_text())
    assert scene["actors"]["v4"]["x"] == replay["tracks"]["v4"]["x"]
    assert scene["actors"]["v4"]["box"] == [9.0, 1.9, 0.0]
    # lanes of the converted road around the cars (x 5-121 m), none of the parked row
    xs = [x for lane in scene["lanes"] for x, _ in lane["points"]]
    ys = [y for lane in scene["lanes"] for _, y in lane["points"]]
    assert len(scene["lanes"]) >= 6 and min(xs) <= 5 and max(xs) >= 121 and min(ys) > -60
    (light,) = scene["lights"]
    assert [span[2] for span in light["spans"]] == ["green", "yellow", "red"]
    assert abs(light["x"] - 200.0) < 3 and abs(light["y"]) < 4  # at the stop line, x = 200
    judged = scene["in_situ"]["judge"]["overall"]
    assert judged["position"]["share"] == 1.0 and judged["samples"] > 250
    assert {f["name"] for f in detail["files"]} >= {"scenario.xosc", "road.xodr",
                                                     "in_situ.json", "replay.json"}
    assert "<OpenDRIVE" in catalog.file_text(runs, KEY, "road.xodr")
    assert catalog.scenario_detail(runs, f"{RUN_ID}/{SCENARIO}")["in_situ"]["key"] == KEY


def test_an_unknown_in_situ_key_is_not_found(runs, tmp_path):
    with pytest.raises(catalog.NotFound):
        catalog.scenario_folder(runs, f"{RUN_ID}/nothing/in_situ")


@pytest.fixture(scope="module")
def in_situ_server(in_situ_scene: Path) -> Iterator[str]:
    import uvicorn

    from scenweave.viewer.app import HOST, create_app

    app = create_app([in_situ_scene.parent.parent])
    served = uvicorn.Server(uvicorn.Config(app, host=HOST, port=0, log_level="warning"))
    thread = threading.Thread(target=served.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not served.started:
        assert time.monotonic() < deadline and thread.is_alive(), "the server did not start"
        time.sleep(0.05)
    yield f"http://{HOST}:{served.servers[0].sockets[0].getsockname()[1]}/"
    served.should_exit = True
    thread.join(timeout=10)


def _at(page, t: float) -> dict[str, list[float]]:
    page.evaluate(f"window.viewer.clock.seek({t})")
    return page.evaluate("window.viewer.player.actorPixels()")


def test_every_vehicle_moves_on_the_recorded_road_while_it_is_recorded(page, in_situ_server,
                                                                      artifacts):
    page.goto(in_situ_server)
    link = page.locator(f"a.in-situ-link[href='#/s/{KEY}']")
    assert "4 vehicles" in link.inner_text() and "100.0 %" in link.inner_text()
    link.click()
    page.wait_for_function("window.viewer && window.viewer.page === 'scenario' "
                           "&& window.viewer.clock !== undefined", timeout=30_000)
    facts = page.inner_text("#in-situ-facts")
    assert "4 vehicles" in facts and "within 0.1 m: 100.00 %" in facts and "worst 0.0" in facts
    assert "replay passed" in page.inner_text(".facts")
    page.select_option("#camera", "whole")
    early = _at(page, 1.0)
    assert set(early) == {"hero", "v3", "v4"}  # v2 appears at 2 s
    page.locator("#scene").screenshot(path=str(artifacts / "in-situ-1s.png"))
    late = _at(page, 6.0)
    assert set(late) == {"hero", "v2", "v4"}  # v3 left at 5 s
    scale = page.evaluate("window.viewer.player.view().scale")
    moved = math.dist(early["hero"], late["hero"]) / scale
    assert moved == pytest.approx(50.0, abs=1.0)  # 10 m/s for 5 s, as recorded
    assert "IN_SITU" in page.inner_text("#findings") or \
        "no IN_SITU_* finding" in page.inner_text("#findings")
    page.click("#in-situ-table summary")
    rows = page.eval_on_selector_all("#in-situ-table tbody tr",
                                     "rows => rows.map(r => r.dataset.vehicle)")
    assert sorted(rows) == sorted(SPANS)
    page.locator("#scene").screenshot(path=str(artifacts / "in-situ-6s.png"))
    page.screenshot(path=str(artifacts / "in-situ-page.png"), full_page=True)


def test_the_static_site_holds_the_in_situ_scene(in_situ_scene, tmp_path):
    result = CliRunner().invoke(cli, ["view", str(in_situ_scene.parent.parent), "--static",
                                      str(tmp_path / "site")])
    assert result.exit_code == 0, result.output
    index = (tmp_path / "site" / "data" / "index.js").read_text()
    assert json.dumps(KEY) in index
    scripts = [p.read_text() for p in (tmp_path / "site" / "data").glob("s*.js")]
    assert any('"in_situ":{"choice"' in text for text in scripts)

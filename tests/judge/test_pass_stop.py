"""Issue 36, item 4: the pass/stop judgement where the ego nearly stops just past the line.

The ego passes the stop line when its front bumper crosses it, as mining reads a pass; the
spawn (the stop line's distance is measured from it) is the ego's reference point, the rear
axle, 3.84 m behind the front. An ego that passes on orange and then slows to a crawl just
past the line, its rear axle still short of it when the scenario ends, has passed.
"""

from __future__ import annotations

import json

import pytest
from lxml import etree

from scenweave import corpus, roads
from scenweave.inputs import InputSelection, load_input
from scenweave.judge.replay import crosses_stop_line_s, judge_replay, travelled
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.player import Playback, replay_file
from scenweave.scenario_lib.vehicles import BOX_CENTRE_AHEAD, VEHICLE_MODELS
from scenweave.spawn_db import SpawnMatcher

STEP_S = 0.05
EGO_LENGTH_M = VEHICLE_MODELS["ego"].length_m
#: the ego's front bumper ahead of its reference point (m)
FRONT_M = EGO_LENGTH_M * (BOX_CENTRE_AHEAD + 0.5)


def passes_then_crawls(line_m: float, crawl_ms: float = 0.3) -> Playback:
    """An ego at 3 m/s that brakes to ``crawl_ms`` once its front is 0.5 m past the line
    ``line_m`` ahead and crawls on to the end: its rear axle ends short of the line."""
    times, speeds, driven, speed = [], [], 0.0, 3.0
    for k in range(int(round(line_m / 3.0 / STEP_S)) + 100):
        times.append(round(k * STEP_S, 3))
        speeds.append(speed)
        driven += speed * STEP_S
        if driven + FRONT_M >= line_m + 0.5:
            speed = max(crawl_ms, speed - 8.0 * STEP_S)
    return Playback(times=times, tracks={"hero": {"speed": speeds}})


def test_the_front_crossing_is_the_pass():
    line = 40.0
    playback = passes_then_crawls(line)
    rear = travelled(playback, "hero", playback.times[-1])
    assert rear + FRONT_M > line > rear  # the front is past, the rear axle is not
    crossed = crosses_stop_line_s(playback, line, EGO_LENGTH_M)
    assert crossed is not None and crossed < playback.times[-1]
    # the rear axle never gets there: what the judge read before (REPLAY_NO_PASS)
    assert crosses_stop_line_s(playback, line + FRONT_M, EGO_LENGTH_M) is None


def test_a_front_short_of_the_line_has_not_passed():
    playback = passes_then_crawls(40.0)
    rear = travelled(playback, "hero", playback.times[-1])
    assert crosses_stop_line_s(playback, rear + FRONT_M + 1.0, EGO_LENGTH_M) is None


@pytest.mark.slow
@pytest.mark.usefixtures("esmini")
def test_a_played_ego_stopping_just_past_the_line_passes(tmp_path, sample_raw):
    """A real U4_3 scenario played in esmini, its ego stopped to a crawl after 3 s: judged
    against a stop line its front crossed but its rear axle did not, it passes; against one
    its front never reached, ``REPLAY_NO_PASS``."""
    loaded = load_input(sample_raw, InputSelection(per_class=1, classes=("U4_3",)))
    params = json.loads(json.dumps(SpawnMatcher().assign(loaded.params[0], 0)))
    path = corpus.generate(params, tmp_path / "U4_3.xosc")
    tree = etree.parse(str(path))
    for speed in tree.xpath("//Action[@name='hero_speed_change']//AbsoluteTargetSpeed"):
        speed.set("value", "0.3")
    for dynamics in tree.xpath("//Action[@name='hero_speed_change']//SpeedActionDynamics"):
        dynamics.set("value", "3.0")
    tree.write(str(path), xml_declaration=True, encoding="utf-8")
    playback = replay_file(path, roads.DEFAULT_MAP_PATH)
    rear = travelled(playback, "hero", playback.duration_s)
    doc = ScenarioDoc(etree.parse(str(path)))

    def codes(line_m: float) -> set[str]:
        judged = dict(params, spawn_stop_line_distance_m=line_m)
        return {f.code for f in judge_replay(playback, judged, doc)}

    assert "REPLAY_NO_PASS" not in codes(rear + FRONT_M / 2)
    assert "REPLAY_NO_PASS" in codes(rear + FRONT_M + 2.0)

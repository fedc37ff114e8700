"""The replay checks (``REPLAY_*``) on scenarios played in the real esmini library.

Every class's scenario of the sample data (spawned on Town04 by the spawn stage) must play back
as recorded; each code is then triggered by a damaged file (or params the file no longer
matches), played for real.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import pytest
from lxml import etree

from scenweave import corpus, roads
from scenweave.inputs import InputSelection, load_input
from scenweave.judge import validate_xosc
from scenweave.judge.replay import judge_collisions_only, judge_replay, lane_changes
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.player import Playback, ReplaySettings, find_esmini, replay_file
from scenweave.spawn_db import SpawnMatcher
from tests.corpus.params_examples import TAGS

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("esmini")]


@pytest.fixture(scope="module")
def sample_params(sample_raw) -> dict[str, dict]:
    """The first sample record of each class, its spawn assigned as a run does."""
    loaded = load_input(sample_raw, InputSelection(per_class=1))
    matcher = SpawnMatcher()
    return {p["maneuver_class"]: matcher.assign(p, 0) for p in loaded.params}


@pytest.fixture
def _scenario(sample_params) -> Callable[[Path, str], tuple[Path, dict]]:
    def make(tmp_path: Path, code: str) -> tuple[Path, dict]:
        params = json.loads(json.dumps(sample_params[code]))
        return corpus.generate(params, tmp_path / f"{code}.xosc"), params
    return make


def _judge(path: Path, params: dict, settings: ReplaySettings | None = None) -> set[str]:
    playback = replay_file(path, roads.DEFAULT_MAP_PATH, settings)
    doc = ScenarioDoc(etree.parse(str(path)))
    return {f.code for f in judge_replay(playback, params, doc)}


def _edit(path: Path, xpath: str, attribute: str, value: Callable[[str], str]) -> None:
    tree = etree.parse(str(path))
    found = tree.getroot().xpath(xpath)
    assert found, xpath
    for element in found:
        element.set(attribute, value(element.get(attribute)))
    tree.write(str(path), xml_declaration=True, encoding="utf-8")


def _event_time(name: str) -> str:
    return f"//Event[Action/@name='{name}']/StartTrigger//SimulationTimeCondition"


def test_esmini_is_found_with_its_version():
    assert find_esmini().version.startswith("v3.6")


@pytest.mark.parametrize("code", sorted(TAGS))
def test_every_corpus_scenario_replays_as_recorded(tmp_path, code, _scenario):
    path, params = _scenario(tmp_path, code)
    result = validate_xosc(path, params, replay=ReplaySettings())
    assert result.replay is not None and result.replay["played"], result.replay
    assert result.valid, [f"{f.code}: {f.message}" for f in result.errors]
    assert result.playback.times[-1] == pytest.approx(params["timeout_s"], abs=0.06)


def _rising_edge_at_zero(path: Path, params: dict) -> None:
    """What the corpus wrote before it used edge none: never fires in esmini at t = 0."""
    _edit(path, "//ByValueCondition/..", "conditionEdge", lambda _: "rising")
    _edit(path, _event_time("hero_speed_change"), "value", lambda _: "0")


def _npc_on_the_ego(path: Path, params: dict) -> None:
    _edit(path, "//Private[@entityRef='npc']//LanePosition", "s",
          lambda _: str(params["ego_s"] + 1.0))


def _unknown_light(path: Path, params: dict) -> None:
    _edit(path, "//TrafficSignalStateAction", "name", lambda _: "pos=0.000,0.000")


def _lane_change_mirrored(path: Path, params: dict) -> None:
    _edit(path, "//RelativeTargetLane", "value", lambda v: str(-int(v)))


def _npc_ends_faster(path: Path, params: dict) -> None:
    _edit(path, "//Action[@name='npc_speed_change']//AbsoluteTargetSpeed", "value",
          lambda v: str(float(v) + 5.0))


def _speed_change_late(path: Path, params: dict) -> None:
    _edit(path, _event_time("npc_speed_change"), "value", lambda v: str(float(v) + 2.0))


def _npc_further_ahead(path: Path, params: dict) -> None:
    _edit(path, "//Private[@entityRef='npc']//LanePosition", "s", lambda v: str(float(v) + 5.0))


def _start_speed_off(path: Path, params: dict) -> None:
    _edit(path, "//Private[@entityRef='hero']//AbsoluteTargetSpeed", "value",
          lambda v: str(float(v) + 3.0))


def _light_never_turns(path: Path, params: dict) -> None:
    _edit(path, "//TrafficSignalStateAction", "state", lambda _: "green")


def _stop_line_closer(path: Path, params: dict) -> None:
    params["spawn_stop_line_distance_m"] -= 15.0


def _ego_halts(path: Path, params: dict) -> None:
    _edit(path, "//Action[@name='hero_speed_change']//AbsoluteTargetSpeed", "value",
          lambda _: "0.0")
    _edit(path, "//Action[@name='hero_speed_change']//SpeedActionDynamics", "value",
          lambda _: "1.0")


def _turn_straight_ahead(path: Path, params: dict) -> None:
    ahead = 40.0
    _edit(path, "//Action[@name='hero_turn_right']//WorldPosition", "x",
          lambda _: str(params["ego_x"] + ahead * math.cos(params["ego_h"])))
    _edit(path, "//Action[@name='hero_turn_right']//WorldPosition", "y",
          lambda _: str(params["ego_y"] + ahead * math.sin(params["ego_h"])))
    _edit(path, "//Action[@name='hero_turn_right']//WorldPosition", "h",
          lambda _: str(params["ego_h"]))


def _lead_turned_round(path: Path, params: dict) -> None:
    _edit(path, "//Private[@entityRef='lead']//WorldPosition", "h",
          lambda v: str(float(v) + math.pi))


def _lead_off_its_lane(path: Path, params: dict) -> None:
    side = params["ego_h"] + math.pi / 2
    _edit(path, "//Private[@entityRef='lead']//WorldPosition", "x",
          lambda v: str(float(v) + 2.2 * math.cos(side)))
    _edit(path, "//Private[@entityRef='lead']//WorldPosition", "y",
          lambda v: str(float(v) + 2.2 * math.sin(side)))


#: code -> (class of the example, damage, every code the damage must raise)
DAMAGE = {
    "REPLAY_EVENT": ("U4_1", _rising_edge_at_zero, {"REPLAY_EVENT", "REPLAY_NO_STOP"}),
    "REPLAY_COLLISION": ("BRAKE", _npc_on_the_ego, {"REPLAY_COLLISION"}),
    "REPLAY_ENGINE": ("U4_3", _unknown_light, {"REPLAY_ENGINE"}),
    "REPLAY_LANE_CHANGE": ("LCF", _lane_change_mirrored, {"REPLAY_LANE_CHANGE"}),
    "REPLAY_SPEED": ("FLF", _npc_ends_faster, {"REPLAY_SPEED"}),
    "REPLAY_SPEED_ONSET": ("FLF", _speed_change_late, {"REPLAY_SPEED_ONSET"}),
    "REPLAY_GAP": ("FLF", _npc_further_ahead, {"REPLAY_GAP"}),
    "REPLAY_START_SPEED": ("LCB", _start_speed_off, {"REPLAY_START_SPEED"}),
    "REPLAY_LIGHT": ("U4_1", _light_never_turns, {"REPLAY_LIGHT"}),
    "REPLAY_STOP_PAST_LINE": ("U4_1", _stop_line_closer, {"REPLAY_STOP_PAST_LINE"}),
    "REPLAY_NO_PASS": ("U4_3", _ego_halts, {"REPLAY_NO_PASS"}),
    "REPLAY_TURN": ("U4_4", _turn_straight_ahead, {"REPLAY_TURN"}),
    "REPLAY_WRONG_WAY": ("U4_2", _lead_turned_round, {"REPLAY_WRONG_WAY"}),
    "REPLAY_OFF_LANE": ("U4_2", _lead_off_its_lane, {"REPLAY_OFF_LANE"}),
}


@pytest.mark.parametrize("code", sorted(DAMAGE))
def test_each_replay_code_fires_on_its_damage(tmp_path, code, _scenario):
    example, damage, expected = DAMAGE[code]
    path, params = _scenario(tmp_path, example)
    assert not _judge(path, params), "the undamaged scenario must replay as recorded"
    damage(path, params)
    codes = _judge(path, params)
    assert expected <= codes, codes


def test_a_replay_past_its_wall_time_is_an_engine_failure_not_a_crash(tmp_path, _scenario):
    path, params = _scenario(tmp_path, "FRF")
    playback = replay_file(path, roads.DEFAULT_MAP_PATH, ReplaySettings(wall_time_s=0.01))
    assert playback.engine_error and "wall_time_s" in playback.engine_error
    assert {f.code for f in judge_collisions_only(playback)} == {"REPLAY_ENGINE"}


def test_replay_leaves_the_delivered_file_as_it_was(tmp_path, _scenario):
    path, params = _scenario(tmp_path, "U4_2")
    before = path.read_bytes()
    replay_file(path, roads.DEFAULT_MAP_PATH)
    assert path.read_bytes() == before
    assert b'name="pos=' in before  # CARLA's light names stay in the delivered file


def test_playback_round_trips_through_its_file(tmp_path, _scenario):
    path, params = _scenario(tmp_path, "CINF")
    playback = replay_file(path, roads.DEFAULT_MAP_PATH)
    playback.write(tmp_path / "replay.json")
    again = Playback.read(tmp_path / "replay.json")
    assert again.to_dict() == json.loads(json.dumps(playback.to_dict()))
    assert lane_changes(again, "npc") == [(lane_changes(playback, "npc")[0][0],
                                            params["lane_change_direction"])]

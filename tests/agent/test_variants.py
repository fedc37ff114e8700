"""``run --vary N``: the LLM writes variants of a delivered scenario, and a variant is kept only
when it changes what the record does not fix and still plays the record (recorded replies,
the real sandbox, validator and esmini replay)."""

from __future__ import annotations

import json

import pytest

from scenweave.agent.llm.log import recent_calls
from scenweave.corpus.worked_example import provenance
from scenweave.inputs import InputSelection, load_input
from scenweave.pipeline import PipelineSettings, process_scenario
from scenweave.player import ReplaySettings
from scenweave.runner import default_matcher, variant_summary
from scenweave.schemas.variation import compare
from tests.agent.conftest import adapted_source, fenced


class AlreadyPlaced:
    """The record carries its spawn already; one lane over is the real matcher's answer."""

    def __init__(self):
        self.matcher = default_matcher()

    def assign(self, params: dict, index: int, top_n: int = 5) -> dict:
        return params

    def lane_over(self, params: dict, index: int = 0) -> dict:
        return self.matcher.lane_over(params, index)


@pytest.fixture(scope="module")
def brake(sample_raw) -> dict:
    """A sample BRAKE record placed by the spawn stage (Town04, road 35, lane -2)."""
    loaded = load_input(sample_raw / "highway", InputSelection(classes=("BRAKE",), limit=1))
    return default_matcher().assign(loaded.params[0], 0)


@pytest.fixture
def varied(brake, replay, esmini, tmp_path):
    right = adapted_source("BRAKE", brake)
    lane_over = default_matcher().lane_over(brake)
    assert (brake["ego_lane_id"], lane_over["ego_lane_id"]) == (-2, -1)
    speed = f'"npc_speed_ms": {brake["npc_speed_ms"]}'
    assert '"weather_key": "Day_Clear"' in right and speed in right
    literal_shift = right.replace('"ego_lane_id": -2', '"ego_lane_id": -1').replace(
        '"npc_lane_id": -2', '"npc_lane_id": -1')
    replies = [fenced(right),  # the faithful scenario, ok on attempt 1
               fenced(right.replace('"Day_Clear"', '"Night_Rain"')),  # weather: kept
               fenced(right.replace(speed, '"npc_speed_ms": 33.0')),  # what the record fixes
               fenced(right),  # nothing changed
               fenced(adapted_source("BRAKE", {**lane_over, **provenance(brake)})),  # kept
               fenced(right.replace('"ego_lane_id": -2', '"ego_lane_id": -1')),  # ego alone
               fenced(right),  # (vehicles: nothing changed)
               fenced(right),  # (traffic: nothing changed)
               fenced(literal_shift)]  # every lane id moved, the spawn stage not asked
    settings = PipelineSettings(no_llm=False, agent=replay(replies), replay=ReplaySettings(),
                                vary=8)
    outcome = process_scenario(brake, 0, tmp_path, settings, AlreadyPlaced())
    return outcome, tmp_path


def test_a_variant_that_changes_the_weather_is_kept(varied):
    outcome, folder = varied
    assert outcome["status"] == "ok"
    weather = outcome["variants"][0]
    assert (weather["aspect"], weather["kept"], weather["changed"]) == ("weather", True,
                                                                       ["weather"])
    assert 'name="Night_Rain"' in (folder / "variants" / "v01" / "scenario.xosc").read_text()
    assert json.loads((folder / "variants" / "v01" / "variant.json").read_text())["kept"]


def test_a_variant_that_changes_what_the_record_fixes_is_not(varied):
    outcome, _ = varied
    speed = outcome["variants"][1]
    assert not speed["kept"]
    assert any(e.startswith("VARY_RECORDED: the variant changes npc's start") for e in
               speed["errors"]), speed["errors"]


def test_a_copy_of_the_faithful_scenario_is_no_variant(varied):
    outcome, _ = varied
    same = outcome["variants"][2]
    assert not same["kept"] and same["changed"] == []
    assert any(e.startswith("VARY_NOTHING") for e in same["errors"])
    assert variant_summary([outcome]) == {"asked": 8, "kept": 2, "records_with_a_variant": 1,
                                          "changed": {"lane": 1, "weather": 1}}


def test_the_record_one_lane_over_where_the_spawn_stage_placed_it_is_kept(varied):
    """The lane variant is asked with the values the spawn stage moved (the neighbouring lane's
    spawn point, every gap measured along the new lanes), and the LLM writes them in."""
    outcome, folder = varied
    lane = outcome["variants"][3]
    assert (lane["aspect"], lane["changed"], lane["kept"]) == ("lane", ["lane"], True), lane
    assert lane["placed"]["ego_lane_id"] == -1
    assert 'laneId="-1"' in (folder / "variants" / "v04" / "scenario.xosc").read_text()
    prompt = _lane_prompts(outcome["scenario_id"])[0]
    assert "- ego_lane_id: -2 -> -1" in prompt and "- npc_lane_id: -2 -> -1" in prompt


def test_one_car_alone_or_every_lane_id_moved_by_hand_is_not_a_lane_variant(varied):
    """Moving lane ids without the spawn stage keeps each car's s: on a curve that breaks the
    recorded gaps, and the starts differ from where the record fits one lane over."""
    outcome, _ = varied
    alone, shifted = outcome["variants"][4], outcome["variants"][7]
    assert shifted["aspect"] == "lane" and not shifted["kept"]
    for variant in (alone, shifted):
        assert not variant["kept"]
        assert any(e.startswith("VARY_RECORDED: the variant changes hero's start")
                   for e in variant["errors"]), variant["errors"]


def test_compare_names_what_changed(varied):
    _, folder = varied
    faithful, lane = folder / "scenario.xosc", folder / "variants" / "v04"
    assert compare(faithful, folder / "variants" / "v01" / "scenario.xosc").changed == ["weather"]
    assert compare(faithful, faithful).changed == []
    moved = compare(faithful, lane / "scenario.xosc", lane / "lane_over.xosc")
    assert (moved.changed, moved.violations) == (["lane"], [])
    unasked = compare(faithful, lane / "scenario.xosc")
    assert unasked.changed == [] and unasked.violations


def test_no_room_one_lane_over_asks_no_lane_variant(brake, replay, esmini, tmp_path):
    """Where the ego's lane has no same-direction neighbour (Town04's road 51 has one lane
    each way), the lane variant gets VARY_NO_LANE and no LLM call is spent on it."""
    lone = AlreadyPlaced()
    lone.lane_over = lambda params, index=0: lone.matcher.lane_over(
        {**params, "ego_road_id": 51, "ego_lane_id": 1, "ego_s": 10.0}, index)
    right = adapted_source("BRAKE", brake)
    settings = PipelineSettings(no_llm=False, agent=replay([fenced(right)] * 4),
                                replay=ReplaySettings(), vary=4)
    outcome = process_scenario(brake, 0, tmp_path, settings, lone)
    lane = outcome["variants"][3]
    assert not lane["kept"] and lane["errors"][0].startswith("VARY_NO_LANE: "), lane
    assert "no same-direction lane beside it" in lane["errors"][0]
    assert not (tmp_path / "variants" / "v04" / "scenario.py").exists()


def _lane_prompts(scenario_id: str) -> list[str]:
    """The prompts of the lane variants, from the local LLM log, oldest first."""
    return [call["prompt"] for call in reversed(recent_calls(50, scenario_id))
            if call["purpose"] == "vary-lane"]

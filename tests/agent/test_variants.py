"""``run --vary N``: the LLM writes variants of a delivered scenario, and a variant is kept only
when it changes what the record does not fix and still plays the record (recorded replies,
the real sandbox, validator and esmini replay)."""

from __future__ import annotations

import json

import pytest

from scenweave import corpus
from scenweave.agent.llm.log import recent_calls
from scenweave.corpus.worked_example import example_params as stored_example
from scenweave.ingest.variants import NotAsked, vary
from scenweave.inputs import InputSelection, load_input
from scenweave.judge.variation import compare
from scenweave.pipeline import PipelineSettings, process_scenario
from scenweave.player import ReplaySettings
from scenweave.runner import default_matcher, variant_summary
from scenweave.scenario_lib.vehicles import bumper_gap_m
from tests.agent.conftest import adapted_source, fenced
from tests.replies import json_edits


def already_placed():
    """The real matcher, but the record carries its spawn already."""
    matcher = default_matcher()
    matcher.assign = lambda params, index, top_n=5: params
    return matcher


@pytest.fixture(scope="module")
def brake(sample_raw) -> dict:
    """A sample BRAKE record placed by the spawn stage (Town04, road 35, lane -2)."""
    loaded = load_input(sample_raw / "highway", InputSelection(classes=("BRAKE",), limit=1))
    return default_matcher().assign(loaded.params[0], 0)



@pytest.fixture(scope="module")
def asked(brake) -> dict[str, dict]:
    """The record as its vehicles and lane variants must play it (first round; ``vehicles2``:
    the second vehicles variant, another model)."""
    matcher = default_matcher()
    return {"vehicles": vary(brake, "vehicles", 0, matcher),
            "vehicles2": vary(brake, "vehicles", 1, matcher),
            "traffic": vary(brake, "traffic", 0, matcher),
            "lane": vary(brake, "lane", 0, matcher)}


@pytest.fixture
def varied(brake, asked, replay, esmini, tmp_path):
    right = adapted_source("BRAKE", brake)
    model = f'"npc_vehicle_type": "{brake["npc_vehicle_type"]}"'
    speed = f'"npc_speed_ms": {brake["npc_speed_ms"]}'
    assert '"weather_key": "Day_Clear"' in right and speed in right and model in right
    new_model = f'"npc_vehicle_type": "{asked["vehicles2"]["npc_vehicle_type"]}"'
    assert (brake["ego_lane_id"], asked["lane"]["ego_lane_id"]) == (-2, -1)
    one_over = right.replace('"ego_lane_id": -2', '"ego_lane_id": -1')
    replies = [fenced(right),  # the faithful scenario, ok on attempt 1
               fenced(right.replace('"Day_Clear"', '"Night_Rain"')),  # v01 weather: kept
               fenced(adapted_source("BRAKE", asked["vehicles"])),  # v02 vehicles: kept
               fenced(adapted_source("BRAKE", asked["traffic"])),  # v03 traffic: kept
               fenced(adapted_source("BRAKE", asked["lane"])),  # v04 lane: kept
               fenced(right.replace(speed, '"npc_speed_ms": 33.0')),  # v05: a recorded value
               fenced(right.replace(model, new_model)),  # v06 vehicles: the model alone
               fenced(right),  # v07 traffic: nothing changed
               fenced(one_over.replace('"npc_lane_id": -2', '"npc_lane_id": -1')),  # v08 by hand
               fenced(one_over)]  # v09 weather: the ego alone one lane over
    settings = PipelineSettings(no_llm=False, agent=replay(replies), replay=ReplaySettings(),
                                vary=9)
    outcome = process_scenario(brake, 0, tmp_path, settings, already_placed())
    return outcome, tmp_path


def _variant(outcome: dict, number: int) -> dict:
    return outcome["variants"][number - 1]


def test_a_variant_that_changes_the_weather_is_kept(varied):
    outcome, folder = varied
    assert outcome["status"] == "ok", outcome["error"]
    weather = _variant(outcome, 1)
    assert (weather["aspect"], weather["kept"], weather["changed"]) == ("weather", True,
                                                                       ["weather"])
    assert 'name="Night_Rain"' in (folder / "variants" / "v01" / "scenario.xosc").read_text()
    assert json.loads((folder / "variants" / "v01" / "variant.json").read_text())["kept"]


def test_a_variant_that_changes_what_the_record_fixes_is_not(varied):
    outcome, _ = varied
    speed = _variant(outcome, 5)
    assert not speed["kept"]
    assert any(e.startswith("VARY_RECORDED: the variant changes npc's start") for e in
               speed["errors"]), speed["errors"]


def test_a_copy_of_the_faithful_scenario_is_no_variant(varied):
    outcome, _ = varied
    same = _variant(outcome, 7)
    assert not same["kept"] and same["changed"] == []
    assert any(e.startswith("VARY_NOTHING") for e in same["errors"])
    assert variant_summary([outcome]) == {
        "asked": 9, "kept": 4, "records_with_a_variant": 1,
        "changed": {"lane": 1, "traffic": 1, "vehicles": 1, "weather": 1}}


def test_background_traffic_is_added_where_the_spawn_stage_found_a_free_lane(brake, asked,
                                                                              varied):
    outcome, folder = varied
    traffic = _variant(outcome, 3)
    assert (traffic["changed"], traffic["kept"]) == (["traffic"], True), traffic
    lane = asked["traffic"]["background_lane_id"]
    assert lane not in (brake["ego_lane_id"], brake["npc_lane_id"])
    assert traffic["asked"]["background_present"] == [None, True]
    scenario = (folder / "variants" / "v03" / "scenario.xosc").read_text()
    assert 'ScenarioObject name="background"' in scenario and f'laneId="{lane}"' in scenario
    prompt = _prompts(outcome["scenario_id"], "vary-traffic")[0]
    assert "- background_present: True" in prompt and f"- background_lane_id: {lane}" in prompt


def test_another_vehicle_model_keeps_the_gap_between_bumpers(brake, asked, varied):
    """A longer or shorter vehicle at the recorded bumper gap stands elsewhere: the variant is
    asked for the moved values and, written in, they replay the record."""
    outcome, _ = varied
    vehicles = _variant(outcome, 2)
    assert (vehicles["changed"], vehicles["kept"]) == (["vehicles"], True), vehicles
    before, after = (p["npc_vehicle_type"] for p in (brake, asked["vehicles"]))
    assert vehicles["asked"]["npc_vehicle_type"] == [before, after]
    bumpers = [bumper_gap_m(p["npc_distance_m"], p["npc_vehicle_type"])
               for p in (brake, asked["vehicles"])]
    assert bumpers[0] == pytest.approx(bumpers[1])
    assert asked["vehicles"]["npc_distance_m"] != brake["npc_distance_m"]
    assert "npc_distance_m" in vehicles["asked"] and "npc_s" in vehicles["asked"]
    prompt = _prompts(outcome["scenario_id"], "vary-vehicles")[0]
    assert f'- npc_vehicle_type: "{before}" -> "{after}"' in prompt
    assert "- npc_distance_m: " in prompt


def test_the_model_changed_alone_leaves_the_recorded_gap(varied):
    outcome, _ = varied
    alone = _variant(outcome, 6)
    assert alone["changed"] == ["vehicles"] and not alone["kept"]
    assert any(e.startswith("VARY_RECORDED: npc's start is not as the reference script plays")
               for e in alone["errors"]), alone["errors"]


def test_the_record_one_lane_over_where_the_spawn_stage_placed_it_is_kept(varied):
    """The lane variant is asked with the values the spawn stage moved (the neighbouring lane's
    spawn point, every gap measured along the new lanes), and the LLM writes them in."""
    outcome, folder = varied
    lane = _variant(outcome, 4)
    assert (lane["aspect"], lane["changed"], lane["kept"]) == ("lane", ["lane"], True), lane
    assert lane["asked"]["ego_lane_id"] == [-2, -1]
    assert 'laneId="-1"' in (folder / "variants" / "v04" / "scenario.xosc").read_text()
    assert (folder / "variants" / "v04" / "reference.xosc").is_file()
    prompt = _prompts(outcome["scenario_id"], "vary-lane")[0]
    assert "- ego_lane_id: -2 -> -1" in prompt and "- npc_lane_id: -2 -> -1" in prompt


def test_one_car_alone_or_lane_ids_moved_by_hand_are_not_lane_variants(varied):
    """The second lane variant is asked for the other side (lane -3); lane ids moved by hand
    to -1 are neither that nor the record, and neither is the ego alone one lane over."""
    outcome, _ = varied
    by_hand, alone = _variant(outcome, 8), _variant(outcome, 9)
    assert by_hand["aspect"] == "lane" and by_hand["asked"]["ego_lane_id"] == [-2, -3]
    for variant in (by_hand, alone):
        assert not variant["kept"]
        assert any(e.startswith("VARY_RECORDED: the variant changes hero's start")
                   for e in variant["errors"]), variant["errors"]
        assert any(e.startswith("VARY_UNASKED: the variant changes the lane by itself")
                   for e in variant["errors"]), variant["errors"]


def test_compare_names_what_changed(varied):
    _, folder = varied
    faithful, lane = folder / "scenario.xosc", folder / "variants" / "v04"
    assert compare(faithful, folder / "variants" / "v01" / "scenario.xosc").changed == ["weather"]
    assert compare(faithful, faithful).changed == []
    moved = compare(faithful, lane / "scenario.xosc", lane / "reference.xosc")
    assert (moved.changed, moved.violations, moved.as_asked) == (["lane"], [], True)
    unasked = compare(faithful, lane / "scenario.xosc")
    assert unasked.changed == ["lane"] and unasked.violations and not unasked.as_asked


def test_the_report_lists_each_records_variants(varied):
    from scenweave.presentation.report import variant_table

    outcome, _ = varied
    html = " ".join(str(cell) for row in variant_table([outcome]).rows for cell in row)
    before, after = _variant(outcome, 2)["asked"]["npc_vehicle_type"]
    assert outcome["scenario_id"] in html and "v01 weather" in html
    assert f"v02 vehicles (npc {before} → {after})" in html
    assert "v04 lane (road 35 lane -1)" in html
    assert "v03 traffic" in html and "v05 (weather) not kept: VARY_RECORDED" in html


def test_no_room_one_lane_over_asks_no_lane_variant(brake, replay, esmini, tmp_path):
    """Where the ego's lane has no same-direction neighbour (Town04's road 51 has one lane
    each way), the lane variant gets VARY_NO_LANE and no LLM call is spent on it."""
    lone = already_placed()
    beside = lone.spawns_beside
    lone.spawns_beside = lambda placed: beside(
        {**placed, "ego_road_id": 51, "ego_lane_id": 1, "ego_s": 10.0})
    right = adapted_source("BRAKE", brake)
    settings = PipelineSettings(no_llm=False, agent=replay([fenced(right)] * 4),
                                replay=ReplaySettings(), vary=4)
    outcome = process_scenario(brake, 0, tmp_path, settings, lone)
    lane = _variant(outcome, 4)
    assert not lane["kept"] and lane["errors"][0].startswith("VARY_NO_LANE: "), lane
    assert "no same-direction lane beside it" in lane["errors"][0]
    assert not (tmp_path / "variants" / "v04" / "scenario.py").exists()


def test_a_record_without_another_vehicle_asks_no_vehicles_variant(brake):
    alone = {**brake, "has_npc": False}
    with pytest.raises(NotAsked) as raised:
        vary(alone, "vehicles", 0, default_matcher())
    assert raised.value.code == "VARY_NO_VEHICLE"


def _prompts(scenario_id: str, purpose: str) -> list[str]:
    """The prompts of one purpose (``vary-lane``) from the local LLM log, oldest first."""
    return [call["prompt"] for call in reversed(recent_calls(50, scenario_id))
            if call["purpose"] == purpose]


def test_with_the_patch_strategy_a_variant_is_json_edits(brake, asked, replay, esmini,
                                                         tmp_path):
    """``--repair patch``: the LLM answers each variant with line edits of the delivered
    script, held to the same grammar as its repairs; the right edits make every aspect."""
    right = adapted_source("BRAKE", brake)
    shown = adapted_source("BRAKE", stored_example(corpus.retrieve(brake).script_path))
    wanted = [right.replace('"Day_Clear"', '"Night_Rain"'),
              *(adapted_source("BRAKE", asked[a]) for a in ("vehicles", "traffic", "lane"))]
    replies = [json_edits(shown, right), *(json_edits(right, w) for w in wanted)]
    settings = PipelineSettings(no_llm=False, agent=replay(replies, repair="patch"),
                                replay=ReplaySettings(), vary=4)
    outcome = process_scenario(brake, 0, tmp_path, settings, already_placed())
    assert (outcome["status"], outcome["attempts"]) == ("ok", 1), outcome["error"]
    assert [(v["changed"], v["kept"]) for v in outcome["variants"]] == [
        (["weather"], True), (["vehicles"], True), (["traffic"], True), (["lane"], True)]
    assert (tmp_path / "variants" / "v01" / "scenario.py").read_text() == wanted[0]
    for number in (2, 3, 4):  # what the reference plays with the values asked
        folder = tmp_path / "variants" / f"v{number:02d}"
        assert (folder / "scenario.xosc").read_bytes() == (folder / "reference.xosc").read_bytes()
    prompt = _prompts(outcome["scenario_id"], "vary-lane")[0]
    assert "Output only the JSON edits." in prompt


def test_an_edit_that_does_not_apply_is_no_variant(brake, replay, esmini, tmp_path):
    right = adapted_source("BRAKE", brake)
    shown = adapted_source("BRAKE", stored_example(corpus.retrieve(brake).script_path))
    wrong = json.dumps({"edits": [{"search": "not a line of it", "replace": "x = 1"}]})
    settings = PipelineSettings(no_llm=False, replay=ReplaySettings(), vary=1,
                                agent=replay([json_edits(shown, right), wrong], repair="patch"))
    outcome = process_scenario(brake, 0, tmp_path, settings, already_placed())
    variant = _variant(outcome, 1)
    assert not variant["kept"] and variant["errors"][0].startswith("VARY_EDIT: edit 1: "), variant

"""``run --vary N``: the LLM writes variants of a delivered scenario, and a variant is kept only
when it changes what the record does not fix and still plays the record (recorded replies,
the real sandbox, validator and esmini replay)."""

from __future__ import annotations

import json

import pytest

from scenweave.pipeline import PipelineSettings, process_scenario
from scenweave.player import ReplaySettings
from scenweave.runner import variant_summary
from scenweave.schemas.variation import compare
from tests.agent.conftest import adapted_source, fenced
from tests.corpus.params_examples import example_params


class AlreadyPlaced:
    """The example params carry their spawn already."""

    def assign(self, params: dict, index: int, top_n: int = 5) -> dict:
        return params


@pytest.fixture
def varied(replay, esmini, tmp_path):
    params = example_params("BRAKE")
    right = adapted_source("BRAKE", params)
    assert '"weather_key": "Day_Clear"' in right and '"npc_speed_ms": 25.0' in right
    replies = [fenced(right),  # the faithful scenario, ok on attempt 1
               fenced(right.replace('"Day_Clear"', '"Night_Rain"')),  # weather: kept
               fenced(right.replace('"npc_speed_ms": 25.0', '"npc_speed_ms": 30.0')),  # fixed
               fenced(right),  # nothing changed
               fenced(right.replace('"ego_lane_id": -3', '"ego_lane_id": -2')
                      .replace('"npc_lane_id": -3', '"npc_lane_id": -2')),  # one lane over
               fenced(right.replace('"ego_lane_id": -3', '"ego_lane_id": -2'))]  # ego alone
    settings = PipelineSettings(no_llm=False, agent=replay(replies), replay=ReplaySettings(),
                                vary=5)
    outcome = process_scenario(params, 0, tmp_path, settings, AlreadyPlaced())
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
    assert variant_summary([outcome]) == {"asked": 5, "kept": 1, "records_with_a_variant": 1,
                                          "changed": {"weather": 1}}


def test_the_whole_scenario_one_lane_over_is_judged_one_car_alone_is_not_a_variant(varied):
    """Every recorded car one lane over is a lane variant; on Town04's curved road 45 the same
    s no longer gives the recorded gap along the new lane, so fidelity refuses it (a kept
    lane variant needs the spawn stage to place the record in that lane)."""
    outcome, folder = varied
    lane, alone = outcome["variants"][3], outcome["variants"][4]
    assert (lane["aspect"], lane["changed"]) == ("lane", ["lane"]), lane
    assert 'laneId="-2"' in (folder / "variants" / "v04" / "scenario.xosc").read_text()
    assert not lane["kept"] and any(e.startswith("FIDELITY_GAP") for e in lane["errors"])
    assert not alone["kept"]
    assert any(e.startswith("VARY_RECORDED: the variant changes hero's start")
               for e in alone["errors"]), alone["errors"]


def test_compare_names_what_changed(varied):
    _, folder = varied
    assert compare(folder / "scenario.xosc", folder / "variants" / "v01" / "scenario.xosc"
                   ).changed == ["weather"]
    assert compare(folder / "scenario.xosc", folder / "scenario.xosc").changed == []
    lane = compare(folder / "scenario.xosc", folder / "variants" / "v04" / "scenario.xosc")
    assert (lane.changed, lane.lane_shift, lane.violations) == (["lane"], 1, [])


def test_the_report_lists_each_records_variants(varied):
    from scenweave.report import _variant_table

    outcome, _ = varied
    html = _variant_table([outcome])
    assert outcome["scenario_id"] in html and "v01 weather" in html
    assert "v02 (vehicles) not kept: VARY_RECORDED" in html

"""validate_xosc: a file per auto-fix rule and per check code that triggers it.

Each case starts from a real corpus scenario (valid, faithful to its params) and changes one
thing; the test asserts that exactly that change is caught, so a check that stops working
fails here.
"""

from __future__ import annotations

import json
import math
import tempfile
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner
from lxml import etree

from scenweave import corpus, roads
from scenweave.cli import cli
from scenweave.judge import run_asam_qc, validate_xosc
from tests.corpus.params_examples import TAGS, example_params

Mutation = Callable[[etree._Element], None]


def _scenario(tmp_path: Path, code: str) -> tuple[Path, dict]:
    params = example_params(code)
    path = corpus.generate(params, tmp_path / f"{code}.xosc")
    return path, params


def _mutate(path: Path, change: Mutation) -> None:
    tree = etree.parse(str(path))
    change(tree.getroot())
    tree.write(str(path), xml_declaration=True, encoding="utf-8")


def _edit_text(path: Path, old: str, new: str, count: int = 1) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, count))


def _remove(xpath: str) -> Mutation:
    def change(root: etree._Element) -> None:
        found = root.xpath(xpath)
        assert found, xpath
        for element in found:
            element.getparent().remove(element)
    return change


def _set(xpath: str, attribute: str, value: str) -> Mutation:
    def change(root: etree._Element) -> None:
        found = root.xpath(xpath)
        assert found, xpath
        for element in found:
            element.set(attribute, value)
    return change


def _codes(result) -> set[str]:
    return {f.code for f in result.errors if f.severity == "error"}


@pytest.mark.parametrize("code", sorted(TAGS))
def test_every_corpus_scenario_is_valid_and_faithful(tmp_path, code):
    path, params = _scenario(tmp_path, code)
    result = validate_xosc(path, params)
    assert result.valid, [f.to_dict() for f in result.errors]
    assert result.domain == params["domain"] and result.fixes_applied == []


@pytest.mark.parametrize("code", ["BRAKE", "CINB", "FRF", "U4_1", "U4_4"])
def test_asam_quality_checker_finds_nothing_in_corpus_scenarios(tmp_path, code):
    path, _ = _scenario(tmp_path, code)
    assert run_asam_qc(path) == []


def test_asam_quality_checker_reports_a_broken_file(tmp_path):
    path, _ = _scenario(tmp_path, "BRAKE")
    _mutate(path, _remove("//Storyboard"))
    assert any("schema" in f.message for f in run_asam_qc(path))


# -- the five auto-fix rules (thesis Table 5.7) ----------------------------------------------

AUTOFIX_CASES = {
    "precipitationIntensity->intensity": (
        "BRAKE", lambda p: _edit_text(p, ' intensity="', ' precipitationIntensity="')),
    "missing TimeOfDay": ("BRAKE", lambda p: _mutate(p, _remove("//TimeOfDay"))),
    "missing Precipitation": ("BRAKE", lambda p: _mutate(p, _remove("//Precipitation"))),
    "spurious </TrafficSignalStateAction>": (
        "U4_1", lambda p: _edit_text(p, "</TrafficSignalAction>",
                                     "</TrafficSignalStateAction></TrafficSignalAction>")),
    "delay expression->0": ("BRAKE", lambda p: _edit_text(p, 'delay="0.0"', 'delay="t+2"')),
}


@pytest.mark.parametrize("rule", sorted(AUTOFIX_CASES))
def test_each_auto_fix_rule_repairs_its_artefact(tmp_path, rule):
    code, damage = AUTOFIX_CASES[rule]
    path, params = _scenario(tmp_path, code)
    damage(path)
    broken = validate_xosc(path, params, fix=False)
    assert not broken.valid
    fixed = validate_xosc(path, params)
    assert fixed.fixes_applied == [rule]
    assert fixed.valid, [f.to_dict() for f in fixed.errors]
    assert validate_xosc(path, params).fixes_applied == []  # the fix was written to the file


# -- Table 5.8 and beyond: one damaged file per check code -----------------------------------

CHECK_CASES: dict[str, tuple[str, Mutation, bool]] = {
    # code: (class, mutation, give params)
    "NO_ROOT": ("BRAKE", lambda r: setattr(r, "tag", "Scenario"), False),
    "NO_STORY": ("BRAKE", _remove("//Story"), False),
    "NO_TELEPORT": ("BRAKE", _remove("//Private[@entityRef='hero']/PrivateAction[TeleportAction]"),
                    False),
    "NO_MANEUVER": ("BRAKE", _remove("//ManeuverGroup"), False),
    "NO_TRIGGER": ("BRAKE", _remove("//StartTrigger"), False),
    "NO_WORLDPOS": ("U4_3", lambda r: setattr(
        r.xpath("//Private[@entityRef='hero']//WorldPosition")[0], "tag", "RoadPosition"), True),
    "NO_TFL_ACTION": ("U4_3", _remove("//ManeuverGroup[@name='traffic_light_group']"), False),
    "ZERO_SPAWN": ("U4_3", lambda r: [_set("//Private[@entityRef='hero']//WorldPosition", a,
                                           "0")(r) for a in "xy"], False),
    "DEFAULT_SPAWN": ("U4_3", lambda r: [_set("//Private[@entityRef='hero']//WorldPosition", a,
                                              v)(r) for a, v in (("x", "312.4"),
                                                                 ("y", "171.8"))], False),
    "NO_LANEPOS": ("BRAKE", lambda r: setattr(
        r.xpath("//Private[@entityRef='hero']//LanePosition")[0], "tag", "RoadPosition"), True),
    "NO_SPEED_ACTION": ("BRAKE", _remove("//AbsoluteTargetSpeed/ancestor::PrivateAction[1]"),
                        True),
    "NPC_MISSING": ("BRAKE", _remove("//ScenarioObject[@name='npc']"), False),
    # a start from standstill is valid; a hero that never moves is not
    "ZERO_SPEED": ("BRAKE", _set("//Private[@entityRef='hero']//AbsoluteTargetSpeed | "
                                 "//Action[starts-with(@name, 'hero_')]//AbsoluteTargetSpeed",
                                 "value", "0"), False),
    "SEM_NO_NPC": ("CINF", _remove("//ScenarioObject[@name='npc']"), False),
    "SEM_NO_LANE_CHANGE": ("LCF", _remove("//Event[Action[@name='hero_lane_change']]"), False),
    "SEM_UNEXPECTED_LANE_CHANGE": ("BRAKE", lambda r: r.xpath(
        "//Maneuver[@name='npc_maneuver']")[0].append(etree.fromstring(
            _event_from("LCF", "hero_lane_change"))), False),
    "SEM_NO_BRAKE": ("BRAKE", _set("//Action[@name='npc_speed_change']//AbsoluteTargetSpeed",
                                   "value", "99"), False),
    "URB_LIGHT_NAME": ("U4_1", _set("//TrafficSignalStateAction", "name", "12"), False),
    "URB_LIGHT_NOT_RED": ("U4_1", _set("//TrafficSignalStateAction", "state", "green"), False),
    "URB_NO_STOP": ("U4_1", _set("//Action[@name='hero_speed_change']//AbsoluteTargetSpeed",
                                 "value", "3.0"), False),
    "URB_LIGHT_START": ("U4_3", _set("//TrafficSignalStateAction", "state", "yellow"), False),
    "URB_RED_ON_GREEN": ("U4_3", _set("//TrafficSignalStateAction", "state", "red"), False),
    "URB_RED_BEFORE_PASS": ("U4_2", lambda r: [_set(f"//Event[@name='traffic_light_{k}_event']"
                                                    "//SimulationTimeCondition", "value", t)(r)
                                               for k, t in (("yellow", "0.2"), ("red", "0.5"))],
                            True),
    # the audit's bad versions: U4_1 braking from t=0 over the recorded time, on green
    "URB_STOP_PAST_LINE": ("U4_1", _set("//Action[@name='hero_speed_change']//"
                                        "SpeedActionDynamics", "value", "7.9"), True),
    "URB_BRAKE_ON_GREEN": ("U4_1", _set("//Action[@name='traffic_light_initial']//"
                                        "TrafficSignalStateAction", "state", "green"), False),
    # U4_2 on an orange record: the light turns yellow only after the ego has passed
    "URB_PASS_ON_GREEN": ("U4_2", lambda r: [_set(f"//Event[@name='traffic_light_{k}_event']"
                                                  "//SimulationTimeCondition", "value", t)(r)
                                             for k, t in (("yellow", "6.0"), ("red", "9.0"))],
                          True),
    # the lead brakes, the ego holds its speed (the corpus before the fix)
    "SEM_COLLISION": ("BRAKE", lambda r: [_set("//Action[@name='hero_speed_change']//" + path,
                                               "value", value)(r) for path, value in (
        ("AbsoluteTargetSpeed", "27.5"), ("SpeedActionDynamics", "3.4"))], True),
    # two events of one Maneuver start together, one overwriting the other (OpenSCENARIO 1.0)
    "SEM_OVERWRITE": ("CINF", _set("//Event[@name='npc_lane_change_event']", "priority",
                                   "overwrite"), False),
    # the cutter changes lanes away from the ego's lane
    "SEM_CUT_IN_LANE": ("CINF", lambda r: _flip_lane(r), True),
    "URB_NO_TURN": ("U4_4", _remove("//Event[Action[@name='hero_turn_right']]"), False),
    "URB_TURN_NOT_RIGHT": ("U4_4", lambda r: _mirror_turn(r), False),
    "URB_TURN_HEADING": ("U4_4", _set("//Action[@name='hero_turn_right']//WorldPosition", "h",
                                      "1.5708"), False),
    # the old fixed offset (stop line + 10 m ahead, 15 m right), not the right movement's exit
    "FIDELITY_TURN": ("U4_4", lambda r: _turn_target_at(r, 24.4 + 10.0, 15.0), True),
    "CARLA_VERSION": ("BRAKE", _set("//FileHeader", "revMinor", "2"), False),
    "CARLA_NO_HERO": ("BRAKE", _set("//Property[@name='type']", "value", "scenario"), False),
    "XSD_INVALID": ("FLB", _set("//FileHeader", "subtitle", "not in the schema"), False),
    "CARLA_UNSUPPORTED": ("BRAKE", lambda r: setattr(
        r.xpath("//Action[@name='npc_speed_change']//SpeedAction")[0], "tag",
        "SynchronizeAction"), False),
    # parameter fidelity
    "FIDELITY_SPEED": ("BRAKE", _set("//Action[@name='npc_speed_change']//AbsoluteTargetSpeed",
                                     "value", "5.0"), True),
    "FIDELITY_SPAWN": ("CINF", _set("//Private[@entityRef='hero']//LanePosition", "s", "1.0"),
                       True),
    # the cutter placed at the recorded gap at t=0: it drifts before the lane change at 2 s
    "FIDELITY_GAP": ("CINF", lambda r: _set("//Private[@entityRef='npc']//LanePosition", "s",
                                            str(_s_at_recorded_gap("CINF")))(r), True),
    "FIDELITY_DIRECTION": ("COUTB", lambda r: _flip_lane(r), True),
    "FIDELITY_DURATION": ("FLB", _set("//Action[@name='npc_speed_change']//SpeedActionDynamics",
                                      "value", "0.5"), True),
    "FIDELITY_TRIGGER": ("U4_1", _set("//Event[@name='traffic_light_yellow_event']//"
                                      "SimulationTimeCondition", "value", "7.5"), True),
    "FIDELITY_TIMEOUT": ("FRB", _set("//Storyboard/StopTrigger//SimulationTimeCondition",
                                     "value", "99"), True),
    "FIDELITY_WEATHER": ("U1_1", _set("//Precipitation", "precipitationType", "rain"), True),
    "FIDELITY_LIGHT": ("U4_3", _set("//TrafficSignalStateAction", "name", "pos=1.000,2.000"),
                       True),
    "FIDELITY_MISSING": ("FRF", _remove("//Event[Action[@name='hero_speed_change']]"), True),
}


def _s_at_recorded_gap(code: str) -> float:
    """``s`` of the example NPC's lane ``npc_distance_m`` along it from the ego's ``s``."""
    p = example_params(code)
    return roads.advance_along_lane(p["npc_road_id"], p["npc_lane_id"], p["ego_s"],
                                    p["npc_distance_m"])[2]


def _event_from(code: str, action: str) -> str:
    path = corpus.generate(example_params(code), Path(tempfile.mkdtemp()) / f"{code}.xosc")
    event = etree.parse(str(path)).xpath(f"//Event[Action[@name='{action}']]")[0]
    event.set("name", "extra_event")
    return etree.tostring(event).decode()


def _flip_lane(root: etree._Element) -> None:
    target = root.xpath("//RelativeTargetLane")[0]
    target.set("value", str(-int(float(target.get("value")))))


def _turn_target_at(root: etree._Element, ahead: float, right: float) -> None:
    spawn = root.xpath("//Private[@entityRef='hero']//WorldPosition")[0]
    target = root.xpath("//Action[@name='hero_turn_right']//WorldPosition")[0]
    x, y, h = (float(spawn.get(k)) for k in "xyh")
    target.set("x", str(x + ahead * math.cos(h) + right * math.sin(h)))
    target.set("y", str(y + ahead * math.sin(h) - right * math.cos(h)))


def _mirror_turn(root: etree._Element) -> None:
    spawn = root.xpath("//Private[@entityRef='hero']//WorldPosition")[0]
    target = root.xpath("//Action[@name='hero_turn_right']//WorldPosition")[0]
    for axis in "xy":
        origin = float(spawn.get(axis))
        target.set(axis, str(2 * origin - float(target.get(axis))))


@pytest.mark.parametrize("check", sorted(CHECK_CASES))
def test_each_check_code_fires_on_its_damage(tmp_path, check):
    code, change, with_params = CHECK_CASES[check]
    path, params = _scenario(tmp_path, code)
    assert check not in _codes(validate_xosc(path, params if with_params else None))
    _mutate(path, change)
    result = validate_xosc(path, params if with_params else None, fix=False)
    assert check in _codes(result), [f.to_dict() for f in result.errors]
    assert not result.valid


WARNING_CASES: dict[str, tuple[str, Mutation]] = {
    "CARLA_BLUEPRINT": ("FLF", _set("//ScenarioObject[@name='npc']/Vehicle", "name", "audi_a2")),
    "CARLA_CATALOG": ("FLF", lambda r: r.xpath("//ScenarioObject[@name='npc']")[0].replace(
        r.xpath("//ScenarioObject[@name='npc']/Vehicle")[0], etree.fromstring(
            '<CatalogReference catalogName="VehicleCatalog" entryName="car1"/>'))),
}


@pytest.mark.parametrize("check", sorted(WARNING_CASES))
def test_each_warning_code_fires_on_its_damage_and_leaves_the_file_valid(tmp_path, check):
    code, change = WARNING_CASES[check]
    path, _ = _scenario(tmp_path, code)
    _mutate(path, change)
    result = validate_xosc(path, fix=False)
    assert [f.code for f in result.errors if f.severity == "warning"] == [check]
    assert result.valid, [f.to_dict() for f in result.errors]


def test_a_scenario_without_a_hero_object_has_no_vehicle_for_carla(tmp_path):
    path, _ = _scenario(tmp_path, "LCF")
    _mutate(path, _set("//ScenarioObject[@name='hero']", "name", "ego"))
    result = validate_xosc(path, fix=False)
    assert "CARLA_NO_HERO" in _codes(result) and not result.valid


@pytest.mark.parametrize("content", [b"\xff\xfe<OpenSCENARIO/>", None],
                         ids=["not-utf8", "missing"])
def test_an_unreadable_file_is_one_finding_naming_it(tmp_path, content):
    path = tmp_path / "s.xosc"
    if content is not None:
        path.write_bytes(content)
    result = validate_xosc(path)
    assert [f.code for f in result.errors] == ["UNREADABLE"] and not result.valid
    assert str(path) in result.errors[0].message


def test_cut_out_that_starts_next_to_the_ego_lane_is_caught(tmp_path):
    path, params = _scenario(tmp_path, "COUTF")
    assert validate_xosc(path, params).valid
    moved = params | {"npc_lane_id": params["npc_lane_id"] - 1}
    assert "SEM_CUT_OUT_LANE" in _codes(validate_xosc(path, moved))


def test_cut_in_that_starts_in_the_ego_lane_is_caught(tmp_path):
    path, params = _scenario(tmp_path, "CINB")
    assert validate_xosc(path, params).valid
    same_lane = params | {"npc_lane_id": params["ego_lane_id"]}
    assert "SEM_CUT_IN_LANE" in _codes(validate_xosc(path, same_lane))


def test_right_turn_before_the_stop_line_is_caught_without_the_maps_exit(tmp_path):
    """Without ``turn_exit_*`` a point 15 m right and 5 m ahead, before the stop line 24.4 m
    ahead, is reached without turning at all."""
    path, params = _scenario(tmp_path, "U4_4")
    _mutate(path, lambda r: _turn_target_at(r, 5.0, 15.0))
    no_exit = params | {f"turn_exit_{k}": None for k in ("x", "y", "z", "h")}
    assert "URB_TURN_BEFORE_LINE" in _codes(validate_xosc(path, no_exit, fix=False))
    assert "FIDELITY_TURN" in _codes(validate_xosc(path, params, fix=False))


@pytest.mark.parametrize("code", ["CINF", "BRAKE", "FRB"])
def test_npc_placed_by_a_difference_in_s_on_a_curved_road_is_caught(tmp_path, code):
    """Road 45 curves: an NPC whose start gap was set as a difference in ``s`` (file and params
    agreeing) is not at that gap along its lane."""
    path, params = _scenario(tmp_path, code)
    actor = "center" if code == "FRB" else "npc"
    entity = "npc_center" if code == "FRB" else "npc"
    along = roads.distance_along_lane(45, params[f"{actor}_lane_id"], params["ego_s"], 45,
                                      params[f"{actor}_lane_id"], params[f"{actor}_s"])
    by_s = params["ego_s"] + along
    assert abs(by_s - params[f"{actor}_s"]) > 0.5  # the curve makes the two differ
    _mutate(path, _set(f"//Private[@entityRef='{entity}']//LanePosition", "s", str(by_s)))
    assert "FIDELITY_GAP" in _codes(validate_xosc(path, params | {f"{actor}_s": by_s}))


def test_stop_line_too_close_for_the_recorded_braking_is_caught(tmp_path):
    """The scenario made for a stop line 24.4 m ahead runs past one 15 m ahead."""
    path, params = _scenario(tmp_path, "U4_1")
    closer = params | {"spawn_stop_line_distance_m": 15.0}
    assert "URB_STOP_PAST_LINE" in _codes(validate_xosc(path, closer))


@pytest.mark.parametrize("value, check", [("$startDelay", "DELAY_PARAM"),
                                          ("t+2", "DELAY_EXPR")])
def test_delay_checks_report_what_auto_fix_would_reset(tmp_path, value, check):
    path, _ = _scenario(tmp_path, "BRAKE")
    _mutate(path, _set("//Condition[@name='npc_speed_change_start']", "delay", value))
    result = validate_xosc(path, fix=False)
    finding = next(f for f in result.errors if f.code == check)
    assert finding.line is not None and finding.line > 1


def test_rounding_in_the_last_shown_digits_is_not_a_fidelity_error(tmp_path):
    path, params = _scenario(tmp_path, "BRAKE")
    target = "//Action[@name='npc_speed_change']//AbsoluteTargetSpeed"
    _mutate(path, _set(target, "value", f"{params['npc_end_speed_ms']:.3f}"))
    assert validate_xosc(path, params).valid


def test_carla_warnings_do_not_make_a_file_invalid(tmp_path):
    path, params = _scenario(tmp_path, "BRAKE")
    _mutate(path, _set("//LogicFile", "filepath", "maps/custom_map"))
    result = validate_xosc(path, params)
    assert result.valid
    assert [f.code for f in result.errors] == ["CARLA_MAP"]


def test_not_xml_at_all(tmp_path):
    path = tmp_path / "broken.xosc"
    path.write_text("<OpenSCENARIO><FileHeader")
    result = validate_xosc(path)
    assert not result.valid and result.errors[0].code == "XML_SYNTAX"


def test_cli_reports_each_file_and_exits_1_when_one_is_invalid(tmp_path):
    good, params = _scenario(tmp_path, "LCB")
    bad, _ = _scenario(tmp_path, "FLF")
    _mutate(bad, _remove("//Story"))
    params_file = tmp_path / "params.json"
    params_file.write_text(json.dumps(params))
    runner = CliRunner()
    ok = runner.invoke(cli, ["validate", str(good), "--params", str(params_file)])
    assert ok.exit_code == 0 and "valid" in ok.output
    both = runner.invoke(cli, ["validate", str(good), str(bad), "--json"])
    assert both.exit_code == 1
    results = {Path(r["file"]).name: r for r in json.loads(both.output)}
    assert results["LCB.xosc"]["valid"] is True
    assert "NO_STORY" in {e["code"] for e in results["FLF.xosc"]["errors"]}


def test_a_start_from_standstill_is_valid(tmp_path):
    """Issue 22: a recorded start from standstill is a valid record; the hero starts at 0
    m/s and its speed action moves it."""
    path, _ = _scenario(tmp_path, "FLF")
    _mutate(path, _set("//Private[@entityRef='hero']//AbsoluteTargetSpeed", "value", "0"))
    result = validate_xosc(path, None, fix=False)
    assert "ZERO_SPEED" not in _codes(result), [f.to_dict() for f in result.errors]

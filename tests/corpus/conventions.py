"""What docs/scenario-conventions.md promises, restated for the tests: where to read each value."""

from __future__ import annotations

import math

import pytest
from lxml import etree

SINGLE_NPC_CLASSES = {"BRAKE", "BR_BK", "CINF", "CINB", "COUTF", "COUTB", "FLF", "FLB"}
BLUEPRINTS = {"car": "vehicle.audi.a2", "truck": "vehicle.carlamotors.carlacola",
              "van": "vehicle.mercedes.sprinter", "motorcycle": "vehicle.yamaha.yzf"}


def action_named(doc: etree._ElementTree, name: str) -> etree._Element:
    (action,) = doc.findall(f".//Story//Action[@name='{name}']")
    return action


def start_time(doc: etree._ElementTree, key: str) -> float:
    (condition,) = doc.findall(f".//Condition[@name='{key}_start']")
    return float(condition.find(".//SimulationTimeCondition").get("value"))


def expected_events(p: dict) -> dict[str, tuple]:
    """Action name -> the values the conventions promise for it."""
    code, start, dur = p["maneuver_class"], p["maneuver_start_s"], p["duration_s"]
    events = {"hero_speed_change": ("speed", p["ego_end_speed_ms"], dur, start)}

    def lane_change(entity: str, v0: float, v1: float) -> tuple:
        sign = 1 if p["lane_change_direction"] == "left" else -1
        return ("lane", sign, max(5.0, (v0 + v1) / 2 * dur), start)

    if code in SINGLE_NPC_CLASSES:
        events["npc_speed_change"] = ("speed", p["npc_end_speed_ms"], dur, start)
    if code in ("CINF", "CINB", "COUTF", "COUTB"):
        events["npc_lane_change"] = lane_change("npc", p["npc_speed_ms"], p["npc_end_speed_ms"])
    if code in ("LCF", "LCB"):
        events["hero_lane_change"] = lane_change("hero", p["ego_speed_ms"], p["ego_end_speed_ms"])
    if code in ("FRF", "FRB"):
        for slot in ("center", "right", "left"):
            if p[f"{slot}_present"]:
                events[f"npc_{slot}_speed_change"] = ("speed", p[f"{slot}_end_speed_ms"], dur,
                                                      start)
    if code == "U4_1":
        events["hero_speed_change"] = ("speed", 0.0, p["brake_time_s"], start)
    if code in ("U4_1", "U4_2", "U4_3", "U4_4"):
        events["traffic_light_initial"] = ("light", "green", 0.0)
    if code == "U4_1" or (code == "U4_2" and p["tfl_state"] == "orange"):
        events["traffic_light_yellow"] = ("light", "yellow", p["yellow_delay_s"])
        events["traffic_light_red"] = ("light", "red", p["yellow_delay_s"] + 3.0)
    if code == "U4_4":
        events["hero_turn_right"] = ("route", start)
    return events


def first_difference(a: etree._Element, b: etree._Element, where: str = "") -> str | None:
    """Where two trees first differ (numbers compared as numbers), or None when they match."""
    where = f"{where}/{a.tag}"
    if a.tag != b.tag or set(a.attrib) != set(b.attrib) or len(a) != len(b):
        return f"{where}: {a.tag}{dict(a.attrib)}[{len(a)}] vs {b.tag}{dict(b.attrib)}[{len(b)}]"
    for key, value in a.attrib.items():
        if (a.tag, key) == ("FileHeader", "date"):  # the parser does not keep the header date
            continue
        other = b.get(key)
        try:
            same = math.isclose(float(value), float(other), abs_tol=1e-9)
        except ValueError:
            same = value == other
        if not same:
            return f"{where}@{key}: {value} vs {other}"
    for x, y in zip(a, b, strict=True):
        found = first_difference(x, y, where)
        if found:
            return found
    return None


def assert_storyboard_matches(doc: etree._ElementTree, p: dict) -> None:
    """Every promised event is there, with the params' values, and nothing else."""
    expected = expected_events(p)
    actions = {a.get("name") for a in doc.findall(".//Story//Action")}
    assert actions == set(expected)
    for name, (kind, *values) in expected.items():
        action = action_named(doc, name)
        if kind == "speed":
            target, duration, start = values
            assert float(action.find(".//AbsoluteTargetSpeed").get("value")) == target
            dynamics = action.find(".//SpeedActionDynamics")
            assert dynamics.get("dynamicsDimension") == "time"
            assert float(dynamics.get("value")) == duration
        elif kind == "lane":
            sign, length, start = values
            assert int(action.find(".//RelativeTargetLane").get("value")) == sign
            dynamics = action.find(".//LaneChangeActionDynamics")
            assert dynamics.get("dynamicsDimension") == "distance"
            assert float(dynamics.get("value")) == pytest.approx(length)
        elif kind == "light":
            state, start = values
            signal = action.find(".//TrafficSignalStateAction")
            assert signal.get("state") == state
            x, y = signal.get("name").removeprefix("pos=").split(",")
            assert (float(x), float(y)) == pytest.approx((p["tfl_x_carla"], p["tfl_y_carla"]),
                                                         abs=5e-4)
        else:
            (start,) = values
            assert action.find(".//AcquirePositionAction/Position/WorldPosition") is not None
        assert start_time(doc, name) == start
    for stop in (doc.find("Storyboard/StopTrigger//Condition[@name='timeout']"),
                 doc.find(".//Act/StopTrigger//Condition[@name='act_stop']")):
        assert float(stop.find(".//SimulationTimeCondition").get("value")) == p["timeout_s"]


def assert_entities_match(doc: etree._ElementTree, p: dict) -> None:
    """The entities the params call for, in order, with their blueprint, spawn and start speed."""
    names = [obj.get("name") for obj in doc.findall("Entities/ScenarioObject")]
    assert names[0] == "hero"
    hero = doc.find("Entities/ScenarioObject[@name='hero']/Vehicle")
    assert hero.get("name") == "vehicle.tesla.model3"
    assert hero.find("Properties/Property[@name='type']").get("value") == "ego_vehicle"
    expected = {"hero": ("ego", p["ego_speed_ms"])}
    if p["maneuver_class"] in SINGLE_NPC_CLASSES:
        expected["npc"] = ("npc", p["npc_speed_ms"])
    for slot in ("center", "right", "left"):
        if p.get(f"{slot}_present"):
            expected[f"npc_{slot}"] = (slot, p[f"{slot}_speed_ms"])
    if p.get("lead_present"):
        expected["lead"] = (None, p["lead_speed_ms"])
    assert names == list(expected)
    for name, (actor, speed) in expected.items():
        private = doc.find(f"Storyboard/Init/Actions/Private[@entityRef='{name}']")
        assert float(private.find(".//AbsoluteTargetSpeed").get("value")) == speed
        position = private.find(".//TeleportAction/Position")[0]
        if p["domain"] == "highway":
            assert position.tag == "LanePosition"
            assert (int(position.get("roadId")), int(position.get("laneId")),
                    float(position.get("s"))) == (p[f"{actor}_road_id"], p[f"{actor}_lane_id"],
                                                  p[f"{actor}_s"])
        elif name == "hero":
            assert position.tag == "WorldPosition"
            assert [float(position.get(k)) for k in "xyzh"] == [p[f"ego_{k}"] for k in "xyzh"]
        else:  # the urban lead, lead_distance_m along the ego heading
            x, y = (float(position.get(k)) for k in "xy")
            assert math.hypot(x - p["ego_x"], y - p["ego_y"]) == pytest.approx(
                p["lead_distance_m"])
            heading = math.atan2(y - p["ego_y"], x - p["ego_x"])
            assert (math.cos(heading), math.sin(heading)) == pytest.approx(
                (math.cos(p["ego_h"]), math.sin(p["ego_h"])))
        if actor in ("npc", "center", "right", "left"):
            vehicle_type = p[f"{actor}_vehicle_type"]
            blueprint = doc.find(f"Entities/ScenarioObject[@name='{name}']/Vehicle").get("name")
            assert blueprint == BLUEPRINTS.get(vehicle_type, BLUEPRINTS["car"])

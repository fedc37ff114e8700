"""What docs/scenario-conventions.md promises, restated for the tests: where to read each value."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from lxml import etree

from scenweave import maneuvers
from scenweave.maneuvers import Maneuver


def _classes_where(has: Callable[[Maneuver], object]) -> set[str]:
    """The registered classes whose definition says so: a class added with the same
    behaviours is held to the same conventions."""
    return {m.code for m in maneuvers.maneuvers() if has(m)}


#: the ego reacts to a braking lead (from t = 0) or a cutter ahead (from its cut-in)
REACTING_CLASSES = _classes_where(lambda m: m.ego_reacts is not None)
SINGLE_NPC_CLASSES = _classes_where(lambda m: m.npc_speed_change)
NPC_LANE_CHANGE_CLASSES = _classes_where(lambda m: m.lane_change == "npc")
EGO_LANE_CHANGE_CLASSES = _classes_where(lambda m: m.lane_change == "hero")
SLOT_CLASSES = _classes_where(lambda m: m.surrounding_slots)
LIGHT_CLASSES = _classes_where(lambda m: m.light is not None)


def follower_prefix(code: str) -> str | None:
    """Whose car shares the ego's lane after the record with nobody reacting (FL, CINB, the FR
    centre slot): it or the ego keeps its distance (``keep_distance_after_record``)."""
    m = maneuvers.get(code)
    if m.ego_reacts is not None:
        return None
    if m.same_lane is not None and m.same_lane.span == "all_along":
        return m.same_lane.prefix
    return "npc" if m.npc_ends_in_ego_lane else None
REACTION_S, YELLOW_PHASE_S, FIRST_LIGHT_CHANGE_S = 1.0, 3.0, 0.5
BLUEPRINTS = {"car": "vehicle.audi.a2", "truck": "vehicle.carlamotors.carlacola",
              "van": "vehicle.mercedes.sprinter", "motorcycle": "vehicle.yamaha.yzf"}


def action_named(doc: etree._ElementTree, name: str) -> etree._Element:
    (action,) = doc.findall(f".//Story//Action[@name='{name}']")
    return action


def start_time(doc: etree._ElementTree, key: str) -> float:
    (condition,) = doc.findall(f".//Condition[@name='{key}_start']")
    return float(condition.find(".//SimulationTimeCondition").get("value"))


def stop_at_line(p: dict) -> tuple[float, float]:
    """U4_1: (start, duration) of the braking that ends 1 m before the spawn's stop line."""
    v0, room = p["ego_speed_ms"], p["spawn_stop_line_distance_m"] - 1.0
    if v0 <= 1e-6:  # standing still
        return 0.0, p["brake_time_s"]
    duration = min(p["brake_time_s"], 2 * room / v0)
    return round((room - v0 * duration / 2) / v0, 3), round(duration, 3)


def time_to_drive(p: dict, metres: float) -> float:
    """When the ego, ``ego_speed_ms`` changing linearly to ``ego_end_speed_ms`` over
    ``duration_s`` from t = 0 (urban), has driven ``metres`` (solved in closed form)."""
    v0, v1, duration = p["ego_speed_ms"], p["ego_end_speed_ms"], p["duration_s"]
    accel = (v1 - v0) / duration
    ramp = (v0 + v1) / 2 * duration
    if metres > ramp:
        return duration + (metres - ramp) / v1
    if accel == 0:
        return metres / v0
    return (-v0 + math.sqrt(v0 * v0 + 2 * accel * metres)) / accel


def light_plan(p: dict) -> tuple[str, float | None]:
    """(initial state, yellow time) of the U4_1 / U4_2 light."""
    if p["maneuver_class"] == "U4_1":
        cue = stop_at_line(p)[0] - REACTION_S
        return ("green" if cue >= FIRST_LIGHT_CHANGE_S else "yellow",
                round(max(cue, FIRST_LIGHT_CHANGE_S), 3))
    if p["maneuver_class"] == "U4_2" and p["tfl_state"] == "orange":
        reached = time_to_drive(p, p["spawn_stop_line_distance_m"] - 5.0)
        return "green", round(max(reached, FIRST_LIGHT_CHANGE_S), 3)
    return "green", None


def expected_events(p: dict) -> dict[str, tuple]:
    """Action name -> the values the conventions promise for it (``None``: checked apart)."""
    code, start, dur = p["maneuver_class"], p["maneuver_start_s"], p["duration_s"]
    events = {"hero_speed_change": ("speed", p["ego_end_speed_ms"], dur, start)}
    if code in REACTING_CLASSES and p["npc_end_speed_ms"] < p["ego_end_speed_ms"]:
        # the reaction's timing depends on the gap: assert_brake_reaction checks it
        events["hero_speed_change"] = ("speed", p["npc_end_speed_ms"], None, None)

    def lane_change(entity: str, v0: float, v1: float) -> tuple:
        sign = 1 if p["lane_change_direction"] == "left" else -1
        return ("lane", sign, max(5.0, (v0 + v1) / 2 * dur), start)

    if code in SINGLE_NPC_CLASSES:
        events["npc_speed_change"] = ("speed", p["npc_end_speed_ms"], dur, start)
    if code in NPC_LANE_CHANGE_CLASSES:
        events["npc_lane_change"] = lane_change("npc", p["npc_speed_ms"], p["npc_end_speed_ms"])
    if code in EGO_LANE_CHANGE_CLASSES:
        events["hero_lane_change"] = lane_change("hero", p["ego_speed_ms"], p["ego_end_speed_ms"])
    if code in SLOT_CLASSES:
        for slot in ("center", "right", "left"):
            if p[f"{slot}_present"]:
                events[f"npc_{slot}_speed_change"] = ("speed", p[f"{slot}_end_speed_ms"], dur,
                                                      start)
    if maneuvers.get(code).stops_at_line:
        brake_start, brake_duration = stop_at_line(p)
        events["hero_speed_change"] = ("speed", 0.0, brake_duration, brake_start)
    initial, yellow = light_plan(p) if code in LIGHT_CLASSES else ("green", None)
    if code in LIGHT_CLASSES:
        events["traffic_light_initial"] = ("light", initial, 0.0)
    if yellow is not None:
        events["traffic_light_yellow"] = ("light", "yellow", yellow)
        events["traffic_light_red"] = ("light", "red", yellow + YELLOW_PHASE_S)
    if maneuvers.get(code).turn == "right":
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


def optional_events(p: dict) -> dict[str, tuple]:
    """Speed changes that follow the record only when the cars would otherwise meet: the
    urban lead keeps ahead from t = 0, the car behind keeps its distance from the record's end
    (whether they are needed is the replay's to judge: a collision)."""
    code, end = p["maneuver_class"], p["maneuver_start_s"] + p["duration_s"]
    optional = {}
    if p["domain"] == "urban" and p.get("lead_present"):
        # the lead keeps ahead of the ego driving as the scenario drives it: at most its
        # fastest, which for a stop at the line (U4_1) is its start speed
        fastest = (p["ego_speed_ms"] if maneuvers.get(code).stops_at_line
                   else max(p["ego_speed_ms"], p["ego_end_speed_ms"]))
        optional["lead_speed_change"] = ("speed", fastest, None, 0.0)
    prefix = follower_prefix(code)
    if prefix is not None and (prefix == "npc" or p.get(f"{prefix}_present")):
        npc = "npc" if prefix == "npc" else f"npc_{prefix}"
        optional["hero_keeps_distance"] = ("speed", p[f"{prefix}_end_speed_ms"], None, end)
        optional[f"{npc}_keeps_distance"] = ("speed", p["ego_end_speed_ms"], None, end)
    return optional


def assert_storyboard_matches(doc: etree._ElementTree, p: dict) -> None:
    """Every promised event is there, with the params' values, and nothing else."""
    expected = expected_events(p)
    actions = {a.get("name") for a in doc.findall(".//Story//Action")}
    optional = optional_events(p)
    assert actions - set(optional) == set(expected)
    expected |= {name: values for name, values in optional.items() if name in actions}
    for name, (kind, *values) in expected.items():
        action = action_named(doc, name)
        if kind == "speed":
            target, duration, start = values
            assert float(action.find(".//AbsoluteTargetSpeed").get("value")) == target
            dynamics = action.find(".//SpeedActionDynamics")
            assert dynamics.get("dynamicsDimension") == "time"
            if duration is not None:
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
        else:  # the right turn ends where the spawn stage found the right movement's exit
            (start,) = values
            target = action.find(".//AcquirePositionAction/Position/WorldPosition")
            assert [float(target.get(k)) for k in "xyzh"] == [p[f"turn_exit_{k}"] for k in "xyzh"]
        if start is not None:
            assert start_time(doc, name) == pytest.approx(start, abs=1e-9), name
    if expected["hero_speed_change"][2] is None:
        assert_brake_reaction(doc, p)
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
    for role in ("lead", "oncoming"):
        if p.get(f"{role}_present"):
            expected[role] = (role, p[f"{role}_speed_ms"])
    assert names == list(expected)
    for name, (actor, speed) in expected.items():
        private = doc.find(f"Storyboard/Init/Actions/Private[@entityRef='{name}']")
        assert float(private.find(".//AbsoluteTargetSpeed").get("value")) == speed
        position = private.find(".//TeleportAction/Position")[0]
        on_lane = p["domain"] == "highway" or (name != "hero" and p.get(f"{actor}_in_junction"))
        if on_lane:  # every highway actor, and an urban one on a junction's connecting road
            assert position.tag == "LanePosition"
            assert (int(position.get("roadId")), int(position.get("laneId")),
                    float(position.get("s"))) == (p[f"{actor}_road_id"], p[f"{actor}_lane_id"],
                                                  p[f"{actor}_s"])
        elif name == "hero":
            assert position.tag == "WorldPosition"
            assert [float(position.get(k)) for k in "xyzh"] == [p[f"ego_{k}"] for k in "xyzh"]
        else:  # the urban lead and oncoming car, where the spawn stage put them
            assert position.tag == "WorldPosition"
            assert [float(position.get(k)) for k in "xyzh"] == [p[f"{actor}_{k}"] for k in "xyzh"]
        if actor in ("npc", "center", "right", "left"):
            vehicle_type = p[f"{actor}_vehicle_type"]
            blueprint = doc.find(f"Entities/ScenarioObject[@name='{name}']/Vehicle").get("name")
            assert blueprint == BLUEPRINTS.get(vehicle_type, BLUEPRINTS["car"])


def assert_brake_reaction(doc: etree._ElementTree, p: dict) -> None:
    """BRAKE, CINF: the ego brakes no harder than the lead or 8 m/s^2 and keeps 2 m between
    the bumpers (or brakes that hard when even that cannot keep them); behind a cutter, from
    the moment it starts to cut in."""
    action = action_named(doc, "hero_speed_change")
    duration = float(action.find(".//SpeedActionDynamics").get("value"))
    target = float(action.find(".//AbsoluteTargetSpeed").get("value"))
    start = start_time(doc, "hero_speed_change")
    t0, lead_duration = p["maneuver_start_s"], p["duration_s"]
    v_ego, v_lead, v_lead_end = p["ego_speed_ms"], p["npc_speed_ms"], p["npc_end_speed_ms"]
    hardest_ms2 = max(8.0, (v_lead - v_lead_end) / lead_duration)
    assert v_ego - target <= hardest_ms2 * duration + 1e-6
    lengths = [float(doc.find(f"Entities/ScenarioObject[@name='{name}']//Dimensions")
                     .get("length")) for name in ("hero", "npc")]
    gap = p["npc_distance_m"] - (v_lead - v_ego) * t0
    ego_x = lead_x = 0.0
    steps = int(p["timeout_s"] / 0.001)
    watch_from = t0 if p["maneuver_class"] == "CINF" else 0.0
    closest = gap if watch_from == 0.0 else math.inf
    for step in range(steps):  # plain Euler integration, independent of scenario_lib.kinematics
        t = step * 0.001
        lead_v = v_lead + (v_lead_end - v_lead) * _ramp(t, t0, lead_duration)
        ego_v = v_ego + (target - v_ego) * _ramp(t, start, duration)
        lead_x += lead_v * 0.001
        ego_x += ego_v * 0.001
        if t + 0.001 >= watch_from:
            closest = min(closest, gap + lead_x - ego_x)
    hardest = duration == pytest.approx(max(v_ego - target, 0.0) / hardest_ms2)
    assert t0 <= start <= t0 + REACTION_S
    assert start == t0 + REACTION_S or hardest  # reacting early only when braking hard is late
    assert closest >= sum(lengths) / 2 + 2.0 - 0.05 or (hardest and start == t0), closest


def _ramp(t: float, start: float, duration: float) -> float:
    """0 before ``start``, 1 after ``start + duration``, linear in between."""
    if t >= start + duration:
        return 1.0
    if t <= start:
        return 0.0
    return max((t - start) / duration, 0.0)

"""Parameter fidelity: read the scenario back and compare every kinematic value with params.

An XSD-valid scenario with a wrong number is a failure (SPEC §8). Where each params key lives
in the file is fixed by docs/scenario-conventions.md; tolerances allow rounding in the last
shown digits (an LLM writing 8.33 for 8.3333) but not a changed value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lxml import etree

from scenweave import maneuvers
from scenweave.judge.findings import Finding
from scenweave.judge.scenario_doc import ScenarioDoc, number, source_line
from scenweave.maneuvers import Maneuver
from scenweave.maneuvers.free_ride import SLOTS
from scenweave.scenario_lib.kinematics import (
    SAFETY_GAP_M,
    YELLOW_PHASE_S,
    SpeedProfile,
    lane_change_length_m,
    lead_reaction,
    orange_light_yellow_s,
    red_light_timing,
    start_gap_m,
    stop_at_line,
)
from scenweave.scenario_lib.lateral import RecordedLaneChange, recorded_lane_change
from scenweave.scenario_lib.phases import (
    PhasesInvalid,
    is_single_ramp,
    lane_change_length,
    phases_of,
    profile_of,
)
from scenweave.schemas.params import Params, actor_value, all_finite, finite

SPEED_TOL_MS = 0.01
TIME_TOL_S = 0.01
POSITION_TOL_M = 0.05
HEADING_TOL_RAD = 1e-3
#: how far the right-turn target may lie from the spawn stage's exit point (m, rad)
TURN_EXIT_TOL_M = 0.5
TURN_EXIT_HEADING_TOL_RAD = 0.05
#: a Fog visual range below this is fog (m)
FOG_BELOW_M = 1000.0
#: what an unknown class must show: nothing beyond what every scenario shows
NO_CLASS = Maneuver(code="", tag="", domain="urban", name="", script="")


def class_of(params: Params) -> Maneuver:
    """The params' class definition (``NO_CLASS`` for a code nobody registered)."""
    return maneuvers.find(params.get("maneuver_class")) or NO_CLASS


@dataclass
class _Check:
    doc: ScenarioDoc
    params: Params
    found: list[Finding]

    def close(self, code: str, what: str, got: float | None, want: float | None, tol: float,
              element: etree._Element | None) -> None:
        if want is None:
            return
        if got is None or not math.isfinite(got) or abs(got - want) > tol:
            self.found.append(Finding(code, f"{what} is {got}, params say {want:.6g}", "error",
                                      source_line(element)))


def fidelity(doc: ScenarioDoc, params: Params) -> list[Finding]:
    """FIDELITY_* findings: every value the scenario takes from ``params`` must match it."""
    check = _Check(doc, params, [])
    _map(check)
    _spawns(check)
    _init_speeds(check)
    _events(check)
    _lights(check)
    _turn_exit(check)
    check.close("FIDELITY_TIMEOUT", "stop-trigger time", doc.stop_time, params.get("timeout_s"),
                TIME_TOL_S, doc.root.find("Storyboard/StopTrigger"))
    _weather(check)
    return check.found


def _map(check: _Check) -> None:
    """``RoadNetwork/LogicFile`` must name the map the params were made for (params ``map``),
    and that map must be known (its lanes are what the gaps are measured on)."""
    want = check.params.get("map")
    if not want:
        return
    logic = check.doc.root.find("RoadNetwork/LogicFile")
    line = source_line(logic)
    if check.doc.logic_file != want:
        check.found.append(Finding("FIDELITY_MAP", f"RoadNetwork/LogicFile names "
                                   f"{check.doc.logic_file!r}, params say map {want!r}",
                                   "error", line))
    elif check.doc.map_path is None:
        check.found.append(Finding("FIDELITY_MAP", f"map {want!r} is neither a bundled town nor "
                                   "an existing .xodr file", "error", line))


def _weather(check: _Check) -> None:
    """The environment's name, rain and time of day must say what ``weather_key`` says."""
    weather = check.params.get("weather_key")
    if not weather:
        return
    root = check.doc.root
    rain = root.find(".//Environment/Weather/Precipitation")
    fog = number(root.find(".//Environment/Weather/Fog"), "visualRange")
    time_of_day = root.find(".//Environment/TimeOfDay")
    hour = int((time_of_day.get("dateTime") or "T12")[11:13] or 12) if time_of_day is not None \
        else None
    seen = {
        "name": check.doc.weather_name,
        "rain": None if rain is None else rain.get("precipitationType") == "rain",
        "fog": None if fog is None else fog < FOG_BELOW_M,
        "night": None if hour is None else not 6 <= hour < 20,
    }
    wanted = {"name": weather, "rain": weather.endswith("_Rain"), "fog": weather.endswith("_Fog"),
              "night": weather.startswith("Night")}
    for what, value in wanted.items():
        if seen[what] is not None and seen[what] != value:
            check.found.append(Finding("FIDELITY_WEATHER", f"environment {what} is "
                                       f"{seen[what]!r}, weather_key {weather!r} says {value!r}"))


def placed_actors(params: Params) -> list[tuple[str, str]]:
    """(entity, params prefix) of every actor the scenario must place, ego first."""
    actors = [("hero", "ego")]
    if params.get("domain") == "highway":
        if params.get("has_npc") and not class_of(params).surrounding_slots:
            actors.append(("npc", "npc"))
        actors += [(f"npc_{slot}", slot) for slot in SLOTS
                   if actor_value(params, slot, "present")]
    else:
        actors += [(role, role) for role in ("lead", "oncoming")
                   if actor_value(params, role, "present")]
    return actors


def _spawns(check: _Check) -> None:
    params = check.params
    highway = params.get("domain") == "highway"
    for entity, prefix in placed_actors(params):
        position = check.doc.spawn_position(entity)
        code = "FIDELITY_SPAWN" if entity == "hero" else "FIDELITY_GAP"
        if position is None:
            check.found.append(Finding("FIDELITY_MISSING", f"{entity} is not placed in Init"))
        elif position.tag == "LanePosition" or (highway and entity == "hero"):
            _lane_position(check, code, entity, prefix, position)
            if highway and entity != "hero":
                _gap_along_lane(check, entity, prefix, position)
        else:  # where the spawn stage put it (the urban lead: on the ego's lane, ahead)
            _world_position(check, code, entity, _pose(params, prefix), position)


Pose = tuple[float, float, float, float]


def _pose(params: Params, prefix: str) -> Pose | None:
    """``(x, y, z, h)`` the spawn stage gave ``prefix``, or None when a key is missing."""
    pose = all_finite(actor_value(params, prefix, "x"), actor_value(params, prefix, "y"),
                      actor_value(params, prefix, "z"), actor_value(params, prefix, "h"))
    if pose is None:
        return None
    x, y, z, h = pose
    return x, y, z, h


def _gap_along_lane(check: _Check, entity: str, prefix: str, position: etree._Element) -> None:
    """A highway NPC stands at t = 0 where its recorded gap holds at ``maneuver_start_s``: the
    recorded gap minus the lead-in drift (``start_gap_m``) ahead of the ego, along its lane
    (on the scenario's map). Measured from beside the ego (``ScenarioDoc.lane_gap``); where the
    NPC's lane id is not found there, walking back that far along the NPC's lane must reach
    the ego's ``s``."""
    params = check.params
    keys = all_finite(actor_value(params, prefix, "distance_m"),
                      actor_value(params, prefix, "speed_ms"), params.get("ego_speed_ms"),
                      params.get("maneuver_start_s"))
    if keys is None:
        return
    distance = keys[0]
    gap = start_gap_m(*keys)
    why = f"(the recorded {distance:g} m at maneuver_start_s minus the lead-in drift)"
    along = check.doc.lane_gap(entity)
    if along is not None:
        if abs(along - gap) > POSITION_TOL_M:
            check.found.append(Finding(
                "FIDELITY_GAP", f"{entity} starts {along:.2f} m ahead of the ego along its "
                f"lane, params say {gap:.2f} m at t = 0 {why}", "error", source_line(position)))
        return
    walked = _walk_back(check.doc, position, gap)
    ego_road, ego_s = actor_value(params, "ego", "road_id"), finite(
        actor_value(params, "ego", "s"))
    if walked is None or ego_road is None or ego_s is None:
        return
    road, back_s = walked
    if str(road) != str(ego_road) or abs(back_s - ego_s) > POSITION_TOL_M:
        check.found.append(Finding(
            "FIDELITY_GAP", f"{entity} is not {gap:.2f} m ahead of the ego along its lane at "
            f"t = 0 {why}: {gap:.2f} m back along its lane is road {road} s={back_s:.2f}, the "
            f"ego starts at road {ego_road} s={ego_s:g}", "error", source_line(position)))


def _walk_back(doc: ScenarioDoc, position: etree._Element, metres: float
               ) -> tuple[str, float] | None:
    """(road, s) ``metres`` back along the lane of a LanePosition, None off the map."""
    road_id, lane, s = position.get("roadId"), number(position, "laneId"), number(position, "s")
    if road_id is None or lane is None or s is None or doc.map_path is None:
        return None
    from scenweave import roads  # here: the map loads once, and only for scenarios that need it

    try:
        road, _, back_s = roads.advance_along_lane(road_id, int(lane), s, -metres,
                                                   map_path=doc.map_path)
    except roads.RoadError:
        return None
    return str(road), back_s


def _lane_position(check: _Check, code: str, entity: str, prefix: str,
                   position: etree._Element) -> None:
    params = check.params
    if position.tag != "LanePosition":
        check.found.append(Finding(code, f"{entity} is placed by <{position.tag}>, params give "
                                   "a lane position", "error", source_line(position)))
        return
    for attribute, want in (("roadId", actor_value(params, prefix, "road_id")),
                            ("laneId", actor_value(params, prefix, "lane_id"))):
        if want is not None and str(position.get(attribute)) != str(int(want)):
            check.found.append(Finding(code, f"{entity} {attribute} is {position.get(attribute)},"
                                       f" params say {int(want)}", "error", source_line(position)))
    check.close(code, f"{entity} s", number(position, "s"),
                finite(actor_value(params, prefix, "s")),
                POSITION_TOL_M, position)


def _world_position(check: _Check, code: str, entity: str, want: Pose | None,
                    position: etree._Element) -> None:
    if want is None:
        return
    if position.tag != "WorldPosition":
        check.found.append(Finding(code, f"{entity} is placed by <{position.tag}>, params give "
                                   "a world position", "error", source_line(position)))
        return
    for axis, value in zip("xyz", want, strict=False):
        check.close(code, f"{entity} {axis}", number(position, axis), value, POSITION_TOL_M,
                    position)
    got_h = number(position, "h")
    if got_h is not None:  # headings equal modulo a full turn
        got_h = want[3] + math.remainder(got_h - want[3], math.tau)
    check.close(code, f"{entity} heading", got_h, want[3], HEADING_TOL_RAD, position)


def _init_speeds(check: _Check) -> None:
    for entity, prefix in placed_actors(check.params):
        if check.doc.spawn_position(entity) is None:
            continue
        check.close("FIDELITY_SPEED", f"{entity} initial speed", check.doc.init_speed(entity),
                    actor_value(check.params, prefix, "speed_ms"), SPEED_TOL_MS,
                    check.doc.init_private(entity))


SpeedChange = tuple[str, float | None, float | None, float | None]


def expected_speed_changes(doc: ScenarioDoc, params: Params) -> list[SpeedChange]:
    """(action name, end speed, duration, start) of every speed change the class must contain."""
    maneuver = class_of(params)
    recorded_ego = params.get("ego_phases") is not None and not _single_ramp(params, "ego")
    hero = _stop_at_line(params) if maneuver.stops_at_line else _npc_reaction(doc, params) \
        if maneuver.ego_reacts and not recorded_ego else None
    changes: list[SpeedChange]
    if hero is not None:
        changes = [("hero_speed_change", hero.end_speed, hero.duration_s, hero.start_s)]
    elif maneuver.stops_at_line:  # without the spawn's stop line only the target is known
        changes = [("hero_speed_change", 0.0, None, None)]
    else:
        changes = _phase_changes(params, "hero", "ego")
    if maneuver.npc_speed_change:
        changes += _phase_changes(params, "npc", "npc")
    if maneuver.surrounding_slots:
        changes += [change for slot in SLOTS if actor_value(params, slot, "present")
                    for change in _phase_changes(params, f"npc_{slot}", slot)]
    return changes


def _phase_changes(params: Params, entity: str, prefix: str) -> list[SpeedChange]:
    """One speed change per phase of ``prefix`` (``corpus.phases``): ``<entity>_speed_change``,
    then ``_2``, ``_3``...; the single ramp when params give no phases."""
    duration, start = params.get("duration_s"), params.get("maneuver_start_s")
    if actor_value(params, prefix, "phases") is None or None in (duration, start):
        return [(f"{entity}_speed_change", actor_value(params, prefix, "end_speed_ms"),
                 duration, start)]
    try:
        phases = phases_of(params, prefix)
    except PhasesInvalid:
        return [(f"{entity}_speed_change", None, None, None)]
    return [(f"{entity}_speed_change" + ("" if i == 0 else f"_{i + 1}"), p.target_ms,
             p.duration_s, p.start_s) for i, p in enumerate(phases)]


def _single_ramp(params: Params, prefix: str) -> bool:
    try:
        return is_single_ramp(params, prefix)
    except (PhasesInvalid, KeyError):
        return True


def _stop_at_line(params: Params) -> SpeedProfile | None:
    """A stop at the light: the ego's braking that ends before the spawn's stop line
    (conventions)."""
    keys = all_finite(params.get("ego_speed_ms"), params.get("brake_time_s"),
                      params.get("spawn_stop_line_distance_m"))
    return None if keys is None else stop_at_line(*keys)


def _npc_reaction(doc: ScenarioDoc, params: Params) -> SpeedProfile | None:
    """A reacting class (BRAKE, CINF): the ego slows to the NPC's end speed after a reaction
    time, if the NPC (braking lead, cutter) ends slower than the ego's recorded end speed
    (conventions)."""
    keys = all_finite(params.get("ego_speed_ms"), params.get("ego_end_speed_ms"),
                      params.get("npc_speed_ms"), params.get("npc_end_speed_ms"),
                      params.get("duration_s"), params.get("maneuver_start_s"),
                      params.get("npc_distance_m"), params.get("timeout_s"))
    ego_length, npc_length = doc.vehicle_length("hero"), doc.vehicle_length("npc")
    if keys is None or ego_length is None or npc_length is None:
        return None
    ego, ego_end, lead, lead_end, duration, start, distance, timeout = keys
    profile = SpeedProfile(lead, lead_end, start, duration) if _single_ramp(params, "npc") \
        else profile_of(params, "npc")
    clearance = (ego_length + npc_length) / 2 + SAFETY_GAP_M
    return lead_reaction(ego, ego_end, profile, start_gap_m(distance, lead, ego, start), timeout,
                         clearance, cut_in=class_of(params).ego_reacts == "from_cut_in")


def _events(check: _Check) -> None:
    params, events = check.params, check.doc.events
    for name, end_speed, duration, start in expected_speed_changes(check.doc, params):
        event = events.get(name)
        if event is None:
            check.found.append(Finding("FIDELITY_MISSING", f"no action {name!r}"))
            continue
        target = event.action.find(".//SpeedActionTarget/AbsoluteTargetSpeed")
        dynamics = event.action.find(".//SpeedActionDynamics")
        check.close("FIDELITY_SPEED", f"{name} target speed", number(target, "value"), end_speed,
                    SPEED_TOL_MS, target)
        check.close("FIDELITY_DURATION", f"{name} duration", number(dynamics, "value"), duration,
                    TIME_TOL_S, dynamics)
        check.close("FIDELITY_TRIGGER", f"{name} start time", event.start_s, start, TIME_TOL_S,
                    event.action)
    actor = class_of(params).lane_change
    if actor:
        _lane_change(check, actor)


def _lane_change(check: _Check, actor: str) -> None:
    params = check.params
    name = f"{actor}_lane_change"
    event = check.doc.events.get(name)
    if event is None:
        check.found.append(Finding("FIDELITY_MISSING", f"no action {name!r}"))
        return
    target = event.action.find(".//RelativeTargetLane")
    direction = params.get("lane_change_direction")
    want = 1.0 if direction == "left" else -1.0 if direction == "right" else None
    got = number(target, "value")
    if want is not None and got != want:
        check.found.append(Finding("FIDELITY_DIRECTION", f"{name} goes {got} lanes, params say "
                                   f"{direction} ({want:+.0f})", "error", source_line(target)))
    prefix = "ego" if actor == "hero" else "npc"
    timed = recorded_lane_change(params, prefix)
    ramp = all_finite(actor_value(params, prefix, "speed_ms"),
                      actor_value(params, prefix, "end_speed_ms"), params.get("duration_s"))
    if timed is not None:
        _timed_lane_change(check, actor, timed)
    elif ramp is not None:
        length = lane_change_length_m(*ramp) if _single_ramp(params, prefix) \
            else lane_change_length(params, prefix)
        dynamics = event.action.find(".//LaneChangeActionDynamics")
        check.close("FIDELITY_DURATION", f"{name} length (duration x speed)",
                    number(dynamics, "value"), length, POSITION_TOL_M + length * 1e-3, dynamics)
    check.close("FIDELITY_TRIGGER", f"{name} start time", event.start_s,
                params.get("maneuver_start_s"), TIME_TOL_S, event.action)


def _timed_lane_change(check: _Check, actor: str, timed: RecordedLaneChange) -> None:
    """A lane change timed from the record (``scenario_lib.lateral``): the move toward the
    new lane takes as long as crossing the line when recorded needs, and the settling part
    starts and lasts as the record says."""
    change = check.doc.events[f"{actor}_lane_change"]
    dynamics = change.action.find(".//LaneChangeActionDynamics")
    check.close("FIDELITY_DURATION", f"{actor}_lane_change length (to cross the line when "
                "recorded)", number(dynamics, "value"), timed.first_m, POSITION_TOL_M, dynamics)
    if timed.settle_start_s is None:
        return
    settle = check.doc.events.get(f"{actor}_lane_settle")
    if settle is None:
        check.found.append(Finding("FIDELITY_MISSING", f"no action '{actor}_lane_settle'"))
        return
    dynamics = settle.action.find(".//LaneChangeActionDynamics")
    check.close("FIDELITY_DURATION", f"{actor}_lane_settle length", number(dynamics, "value"),
                timed.settle_m, POSITION_TOL_M, dynamics)
    check.close("FIDELITY_TRIGGER", f"{actor}_lane_settle start time", settle.start_s,
                timed.settle_start_s, TIME_TOL_S, settle.action)


def _lights(check: _Check) -> None:
    params = check.params
    if params.get("domain") != "urban" or (class_of(params) is not NO_CLASS
                                            and class_of(params).light is None):
        return
    x, y = params.get("tfl_x_carla"), params.get("tfl_y_carla")
    wanted = f"pos={x:.3f},{y:.3f}" if x is not None and y is not None else None
    events = check.doc.events
    initial, yellow = _light_plan(params)
    timing: dict[str, tuple[float | None, str]] = {"traffic_light_initial": (0.0, initial)}
    if class_of(params).stops_at_line or params.get("tfl_state") == "orange":
        timing["traffic_light_yellow"] = (yellow, "yellow")
        timing["traffic_light_red"] = (None if yellow is None else yellow + YELLOW_PHASE_S, "red")
    for name, (start, state) in timing.items():
        event = events.get(name)
        if event is None:
            check.found.append(Finding("FIDELITY_MISSING", f"no action {name!r}"))
            continue
        light = event.action.find(".//TrafficSignalStateAction")
        if wanted and (light is None or light.get("name") != wanted):
            check.found.append(Finding("FIDELITY_LIGHT", f"{name} controls "
                                       f"{None if light is None else light.get('name')!r}, "
                                       f"params say {wanted!r}", "error",
                                       source_line(event.action)))
        if light is not None and (light.get("state") or "").lower() != state:
            check.found.append(Finding("FIDELITY_LIGHT", f"{name} shows {light.get('state')!r}, "
                                       f"the scenario needs {state!r} then", "error",
                                       source_line(light)))
        check.close("FIDELITY_TRIGGER", f"{name} time", event.start_s, start, TIME_TOL_S,
                    event.action)


def _turn_exit(check: _Check) -> None:
    """A right turn: the ego is routed to the exit the spawn stage found on the map
    (``turn_exit_*``: into the lane the junction's right movement leads to), not to a point
    nearby."""
    params = check.params
    want = _pose(params, "turn_exit")
    if class_of(params).turn != "right" or want is None:
        return
    event = check.doc.events.get("hero_turn_right")
    target = None if event is None else event.action.find(
        ".//AcquirePositionAction/Position/WorldPosition")
    if target is None:
        check.found.append(Finding("FIDELITY_MISSING", "no AcquirePositionAction "
                                   "'hero_turn_right' with a WorldPosition"))
        return
    for axis, value in zip("xy", want, strict=False):
        check.close("FIDELITY_TURN", f"right-turn target {axis} (the right movement's exit "
                    "lane)", number(target, axis), value, TURN_EXIT_TOL_M, target)
    got_h = number(target, "h")
    if got_h is not None:  # headings equal modulo a full turn
        got_h = want[3] + math.remainder(got_h - want[3], math.tau)
    check.close("FIDELITY_TURN", "right-turn target heading", got_h, want[3],
                TURN_EXIT_HEADING_TOL_RAD, target)


def _light_plan(params: Params) -> tuple[str, float | None]:
    """(state at t = 0, time the light turns yellow) the class's light follows (conventions)."""
    if class_of(params).stops_at_line:
        stop = _stop_at_line(params)
        return ("green", None) if stop is None else red_light_timing(stop)
    keys = all_finite(params.get("ego_speed_ms"), params.get("ego_end_speed_ms"),
                      params.get("maneuver_start_s"), params.get("duration_s"),
                      params.get("spawn_stop_line_distance_m"))
    if keys is None:
        return "green", None
    v0, v1, start, duration, stop_line = keys
    ego = SpeedProfile(v0, v1, start, duration) if _single_ramp(params, "ego") \
        else profile_of(params, "ego")
    return "green", orange_light_yellow_s(ego, stop_line)

"""Building blocks shared by every reference script: actors, actions, triggers, make_scenario().

The reference scripts (``corpus/gen_hw_*.py``, ``corpus/gen_ur_*.py``) and the scripts the
LLM adapts from them describe *what* happens in a manoeuvre; this module knows *how* that is
written in OpenSCENARIO 1.0 for CARLA's scenario_runner. Every name, unit and formula used here
is documented in ``docs/scenario-conventions.md`` so that a validator can read the scenario back.

This module runs inside the sandbox too, where only the ``scenario_lib`` folder and
``scenariogeneration`` exist: it imports nothing else from ScenWeave.
"""

from __future__ import annotations

import datetime as dt
import math
import numbers
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenariogeneration import xosc

from scenweave.scenario_lib.kinematics import (
    MAX_PLAYABLE_DECELERATION_MS2,
    YELLOW_PHASE_S,
    SpeedProfile,
    follower_settles,
    lane_change_length_m,
    lead_reaction,
    lead_stays_ahead,
    orange_light_yellow_s,
    red_light_timing,
    start_gap_m,
    stop_at_line,
)
from scenweave.scenario_lib.lateral import recorded_lane_change, road_offset
from scenweave.scenario_lib.phases import (
    Phase,
    PhasedProfile,
    PhasesInvalid,
    is_single_ramp,
    lane_change_length,
    parse_phases,
    profile_of,
)
from scenweave.scenario_lib.vehicles import (
    BOX_CENTRE_AHEAD,
    VEHICLE_MODELS,
    clearance_m,
    known_type,
)

HERO = "hero"
XML_DECLARATION = '<?xml version="1.0" encoding="utf-8"?>\n'
#: the map a scenario names when its params name none (params ``map``, docs/params.md)
MAP_NAME = "Town04"
AUTHOR = "ScenWeave"
#: a fixed header date, so that the same params always give byte-identical files
HEADER_DATE = dt.datetime(2026, 1, 1, 0, 0, 0)

#: RelativeTargetLane sign: +1 is one lane to the left of the driving direction, as in the
#: OpenSCENARIO standard and scenario_runner since 0.9.12 (its issue #767; before, it was mirrored)
LANE_CHANGE_SIGN = {"left": 1, "right": -1}
#: params colour of a light -> TrafficSignalStateAction state
LIGHT_STATES = {"green": "green", "orange": "yellow", "yellow": "yellow", "red": "red"}


@dataclass(frozen=True)
class Weather:
    """How one ``weather_key`` is written: time of day, clouds, sun, rain."""

    hour: int
    clouds: Any
    sun_intensity: float
    sun_elevation_rad: float
    rain_intensity: float
    #: how far one sees (m); 100 km: no fog (an int, so the file keeps writing "100000")
    visual_range_m: float = 100000


WEATHERS: dict[str, Weather] = {
    "Day_Clear": Weather(12, xosc.CloudState.free, 1.0, 1.0, 0.0),
    "Day_Cloudy": Weather(12, xosc.CloudState.cloudy, 0.2, 1.0, 0.0),
    "Day_Rain": Weather(12, xosc.CloudState.rainy, 0.1, 1.0, 0.6),
    "Night_Clear": Weather(22, xosc.CloudState.free, 1.0, -0.5, 0.0),
    "Night_Rain": Weather(22, xosc.CloudState.rainy, 0.1, -0.5, 0.6),
    "Day_Fog": Weather(12, xosc.CloudState.overcast, 0.2, 1.0, 0.0, visual_range_m=80.0),
    "Night_Fog": Weather(22, xosc.CloudState.overcast, 0.1, -0.5, 0.0, visual_range_m=50.0),
}


@dataclass(frozen=True)
class Actor:
    """One vehicle of the scenario: its role name, model, start position and start speed."""

    name: str
    vehicle_type: str
    position: Any
    speed_ms: float


@dataclass(frozen=True)
class StoryEvent:
    """One storyboard event and the ManeuverGroup (entity or ``traffic_light``) it belongs to."""

    group: str
    event: xosc.Event


# --- params ----------------------------------------------------------------------------------

def number(params: Mapping[str, Any], key: str) -> float:
    """``params[key]`` when it is a finite number; otherwise an error naming the key."""
    value: float = finite(f"params key {key!r}", params[key])  # as given: an int stays an int
    return value


def finite(what: str, value: Any) -> Any:
    """``value`` when it is a finite number; otherwise a ValueError naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        hint = " (spawn keys stay null until spawn_db fills them)" if value is None else ""
        raise ValueError(f"{what} must be a finite number, not {value!r}{hint}")
    return value


def integer(params: Mapping[str, Any], key: str) -> int:
    """``params[key]`` as an int (OpenDRIVE ids; scenario_runner parses them with int())."""
    value = number(params, key)
    if value != int(value):
        raise ValueError(f"params key {key!r} must be a whole number, not {value!r}")
    return int(value)


def manoeuvre_timing(params: Mapping[str, Any]) -> tuple[float, float]:
    """``(duration_s, maneuver_start_s)``: how long the manoeuvre lasts and when it starts."""
    return number(params, "duration_s"), number(params, "maneuver_start_s")


# --- positions -------------------------------------------------------------------------------

def lane_position(params: Mapping[str, Any], actor: str) -> xosc.LanePosition:
    """The LanePosition the spawn stage chose for ``actor`` (``ego``, ``npc``, a FR slot), on
    its lane's centre or as far off it as recorded (``<actor>_lane_offset_m``)."""
    return xosc.LanePosition(number(params, f"{actor}_s"), road_offset(params, actor),
                             integer(params, f"{actor}_lane_id"),
                             integer(params, f"{actor}_road_id"))


def world_position(params: Mapping[str, Any], actor: str) -> xosc.WorldPosition:
    """The WorldPosition (OpenSCENARIO frame) the spawn stage chose for ``actor``."""
    return xosc.WorldPosition(*(number(params, f"{actor}_{axis}") for axis in "xyzh"))


def road_position(params: Mapping[str, Any], actor: str) -> Any:
    """Where an urban NPC starts: its WorldPosition, or its LanePosition when the spawn stage
    put it on a junction's connecting road (``<actor>_in_junction``). Connecting roads overlap
    there, and a player snaps a world position to whichever is closest: possibly one that
    turns off the ego's path."""
    if params.get(f"{actor}_in_junction"):
        return lane_position(params, actor)
    return world_position(params, actor)


# --- actors ----------------------------------------------------------------------------------

def hero(position: Any, speed_ms: float) -> Actor:
    """The ego vehicle, named ``hero`` as CARLA expects."""
    return Actor(HERO, "ego", position, finite("the hero's start speed", speed_ms))


def npc(name: str, position: Any, speed_ms: float, vehicle_type: str | None) -> Actor:
    """A scripted vehicle; unknown types become a car."""
    return Actor(name, known_type(vehicle_type), position,
                 finite(f"the start speed of {name}", speed_ms))


def background_traffic(params: Mapping[str, Any]) -> list[Actor]:
    """The background vehicle of a ``--vary`` traffic variant, when ``background_present``:
    it starts where the spawn stage put it (a lane the record does not use), at
    ``background_speed_ms``, and holds that speed."""
    if not params.get("background_present"):
        return []
    return [npc("background", lane_position(params, "background"),
                number(params, "background_speed_ms"), params.get("background_vehicle_type"))]


def highway_npc(params: Mapping[str, Any]) -> Actor:
    """The highway NPC (lead, cutter or follower) where the spawn stage put it for t = 0 (its
    recorded gap holds when the manoeuvre starts)."""
    return npc("npc", lane_position(params, "npc"), number(params, "npc_speed_ms"),
               params.get("npc_vehicle_type"))


def free_ride_traffic(params: Mapping[str, Any]) -> tuple[list[Actor], list[StoryEvent]]:
    """The vehicles of the present free-ride slots, each changing speed as recorded."""
    actors, events = [], []
    for slot in ("center", "right", "left"):
        if not params.get(f"{slot}_present"):
            continue
        name = f"npc_{slot}"
        actors.append(npc(name, lane_position(params, slot), number(params, f"{slot}_speed_ms"),
                          params.get(f"{slot}_vehicle_type")))
        events += speed_profile(params, name, slot)
        if slot == "center":  # the ego's own lane
            events += keep_distance_after_record(params, name, slot)
    return actors, events


def urban_lead(params: Mapping[str, Any]) -> list[Actor]:
    """The urban lead vehicle, when the record had one: ``lead_distance_m`` ahead of the ego
    along its lane, where the spawn stage put it (``lead_*`` spawn keys)."""
    if not params.get("lead_present"):
        return []
    return [npc("lead", road_position(params, "lead"), number(params, "lead_speed_ms"),
                params.get("lead_vehicle_type"))]


def keep_distance_after_record(params: Mapping[str, Any], entity: str = "npc",
                               prefix: str = "npc") -> list[StoryEvent]:
    """After the recorded manoeuvre, whichever of the ego and ``entity`` drives behind in one
    lane slows to the other's end speed when it would otherwise come closer than the safety
    distance before ``timeout_s`` (``<follower>_keeps_distance``); none when not needed.

    The record ends with the manoeuvre; a scenario runs on to ``timeout_s``, and two cars held
    at their end speeds would collide where the record never shows them.
    """
    duration, start = manoeuvre_timing(params)
    end = start + duration
    ego, other = motion(params, "ego"), motion(params, prefix)
    gap = (number(params, f"{prefix}_distance_m") + other.distance(end) - other.distance(start)
           - ego.distance(end) + ego.distance(start))
    clearance = clearance_m(params.get(f"{prefix}_vehicle_type"))
    follower, leader = ((entity, ego) if gap < 0 else (HERO, other))
    follower_speed = (other if follower == entity else ego).end_speed
    settle = follower_settles(follower_speed, leader.end_speed, abs(gap),
                              number(params, "timeout_s") - end, clearance)
    if settle is None:
        return []
    return [speed_change(follower, leader.end_speed, round(settle, 3), end, "keeps_distance")]


def urban_traffic(params: Mapping[str, Any]) -> list[Actor]:
    """The record's other vehicles in town: the lead ahead in the ego's lane and the oncoming
    car in the other direction's lane, where the spawn stage put them (``lead_*``,
    ``oncoming_*``), each at its recorded speed."""
    traffic = urban_lead(params)
    if params.get("oncoming_present"):
        traffic.append(npc("oncoming", road_position(params, "oncoming"),
                           number(params, "oncoming_speed_ms"),
                           params.get("oncoming_vehicle_type")))
    return traffic


def lead_keeps_ahead(params: Mapping[str, Any],
                     ego_stops_at_line: bool = False) -> list[StoryEvent]:
    """The urban lead's ``lead_speed_change`` when the ego, driving as recorded (stopping at
    the line if ``ego_stops_at_line``), would catch it up before ``timeout_s``
    (``scenario_lib.kinematics.lead_stays_ahead``); none otherwise."""
    if not params.get("lead_present"):
        return []
    clearance = clearance_m(params.get("lead_vehicle_type"))
    hero = urban_hero_profile(params, ego_stops_at_line)
    profile = lead_stays_ahead(number(params, "lead_speed_ms"), hero,
                               number(params, "lead_distance_m"), number(params, "timeout_s"),
                               clearance)
    return [] if profile is None else [_profile_change("lead", profile)]


def urban_hero_profile(params: Mapping[str, Any],
                       stops_at_line: bool) -> SpeedProfile | PhasedProfile:
    """How the urban ego drives: the stop at the line or its recorded speed profile."""
    if stops_at_line:
        return stop_at_line(number(params, "ego_speed_ms"), number(params, "brake_time_s"),
                            stop_line_m(params))
    return motion(params, "ego")


def _vehicle(actor: Actor) -> xosc.Vehicle:
    model = VEHICLE_MODELS[actor.vehicle_type]
    box = xosc.BoundingBox(model.width_m, model.length_m, model.height_m,
                           model.length_m * BOX_CENTRE_AHEAD, 0, model.height_m / 2)
    front = xosc.Axle(0.5, 0.7, model.width_m * 0.85, model.length_m * 0.6, 0.35)
    rear = xosc.Axle(0.0, 0.7, model.width_m * 0.85, 0.0, 0.35)
    vehicle = xosc.Vehicle(model.blueprint, xosc.VehicleCategory[model.category], box, front, rear,
                           model.max_speed_ms, MAX_PLAYABLE_DECELERATION_MS2,
                           MAX_PLAYABLE_DECELERATION_MS2)
    if actor.name == HERO:
        vehicle.add_property("type", "ego_vehicle")
    return vehicle


# --- actions and events ----------------------------------------------------------------------

def at_time(name: str, time_s: float, point: str = "start") -> xosc.ValueTrigger:
    """A start (or ``point="stop"``) trigger firing once the simulation time exceeds ``time_s``.

    Edge ``none``: a time condition that is already true when first evaluated (``time_s`` = 0)
    has no rising edge, and esmini never fires it ("simulationTime = 0 condition used with
    edge rising which could be missed"); each event runs once, so ``none`` fires it once.
    """
    return xosc.ValueTrigger(name, 0, xosc.ConditionEdge.none,
                             xosc.SimulationTimeCondition(time_s, xosc.Rule.greaterThan), point)


def story_event(group: str, key: str, action: Any, start_s: float) -> StoryEvent:
    """Event ``<key>_event`` holding action ``<key>``, started at ``start_s``.

    Priority ``parallel``: events of one Maneuver that start together (a lane change and a
    speed change) both run; under OpenSCENARIO 1.0 ``overwrite`` would end the other one.
    """
    finite(f"the start time of {key}", start_s)
    event = xosc.Event(f"{key}_event", xosc.Priority.parallel)
    event.add_action(key, action)
    event.add_trigger(at_time(f"{key}_start", start_s))
    return StoryEvent(group, event)


def speed_change(entity: str, target_ms: float, duration_s: float, start_s: float,
                 key: str = "speed_change", shape: str = "linear") -> StoryEvent:
    """``entity`` goes to ``target_ms`` within ``duration_s`` from ``start_s``, linearly or
    along another of OpenSCENARIO's ``shape``s (action ``<entity>_<key>``)."""
    finite(f"the target speed of {entity}", target_ms)
    finite(f"the speed change duration of {entity}", duration_s)
    dynamics = xosc.TransitionDynamics(getattr(xosc.DynamicsShapes, shape),
                                       xosc.DynamicsDimension.time, duration_s)
    return story_event(entity, f"{entity}_{key}",
                       xosc.AbsoluteSpeedAction(target_ms, dynamics), start_s)


def _profile_change(entity: str, profile: SpeedProfile) -> StoryEvent:
    return speed_change(entity, profile.end_speed, profile.duration_s, profile.start_s)


def lane_change(entity: str, direction: str, v_start_ms: float, v_end_ms: float,
                duration_s: float, start_s: float, length_m: float | None = None) -> StoryEvent:
    """``entity`` moves one lane to ``direction`` (left/right) over ``duration_s`` (driving
    ``length_m`` meanwhile; by default as a linear speed change from ``v_start_ms`` to
    ``v_end_ms`` does)."""
    if direction not in LANE_CHANGE_SIGN:
        raise ValueError(f"lane_change_direction must be 'left' or 'right', not {direction!r}")
    length = lane_change_length_m(v_start_ms, v_end_ms, duration_s) if length_m is None \
        else finite(f"the lane change length of {entity}", length_m)
    dynamics = xosc.TransitionDynamics(xosc.DynamicsShapes.linear,
                                       xosc.DynamicsDimension.distance, length)
    action = xosc.RelativeLaneChangeAction(LANE_CHANGE_SIGN[direction], entity, dynamics)
    return story_event(entity, f"{entity}_lane_change", action, start_s)


def recorded_lane_change_events(params: Mapping[str, Any], entity: str,
                                 prefix: str) -> list[StoryEvent] | None:
    """A mined lane change as recorded (``scenario_lib.lateral``): toward the new lane so
    as to cross the line when the car did, then settling in it by the end of ``duration_s``,
    each linear over the distance the car drives meanwhile; None when params do not time the
    crossing."""
    timing = recorded_lane_change(params, prefix)
    direction = params["lane_change_direction"]
    if timing is None or direction not in LANE_CHANGE_SIGN:
        return None
    toward = xosc.TransitionDynamics(xosc.DynamicsShapes.linear,
                                     xosc.DynamicsDimension.distance, timing.first_m)
    events = [story_event(entity, f"{entity}_lane_change", xosc.RelativeLaneChangeAction(
        LANE_CHANGE_SIGN[direction], entity, toward), timing.start_s)]
    if timing.settle_start_s is not None and timing.settle_m is not None:
        settle = xosc.TransitionDynamics(xosc.DynamicsShapes.linear,
                                         xosc.DynamicsDimension.distance, timing.settle_m)
        events.append(story_event(entity, f"{entity}_lane_settle",
                                  xosc.RelativeLaneChangeAction(0, entity, settle),
                                  timing.settle_start_s))
    return events


def hero_speed_profile(params: Mapping[str, Any]) -> list[StoryEvent]:
    """The recorded ego speed profile: its phases (``ego_phases``), or ``ego_end_speed_ms``
    over ``duration_s``."""
    return speed_profile(params, HERO, "ego")


def npc_speed_profile(params: Mapping[str, Any]) -> list[StoryEvent]:
    """The recorded NPC speed profile: its phases (``npc_phases``), or ``npc_end_speed_ms``
    over ``duration_s``."""
    return speed_profile(params, "npc", "npc")


def speed_profile(params: Mapping[str, Any], entity: str, prefix: str) -> list[StoryEvent]:
    """``entity``'s recorded speed profile, one speed action per phase: ``<prefix>_phases``
    when params give them, else the single ramp to ``<prefix>_end_speed_ms`` over
    ``duration_s`` from ``maneuver_start_s`` (the same event as a one-phase list gives)."""
    if params.get(f"{prefix}_phases") is None:
        return [speed_change(entity, number(params, f"{prefix}_end_speed_ms"),
                             *manoeuvre_timing(params))]
    return speed_phases(entity, phases(params, prefix))


def phases(params: Mapping[str, Any], prefix: str) -> tuple[Phase, ...]:
    """``<prefix>_phases`` checked; an error naming the key when it is no playable list."""
    try:
        return parse_phases(params[f"{prefix}_phases"], f"params key {prefix + '_phases'!r}")
    except PhasesInvalid as err:
        raise ValueError(str(err)) from err


def speed_phases(entity: str, profile: Iterable[Phase]) -> list[StoryEvent]:
    """One speed action per phase, chained by time: ``<entity>_speed_change`` for the first,
    ``<entity>_speed_change_2``, ``_3``... for the next ones (docs/scenario-conventions.md)."""
    return [speed_change(entity, phase.target_ms, phase.duration_s, phase.start_s,
                         "speed_change" if i == 0 else f"speed_change_{i + 1}", phase.shape)
            for i, phase in enumerate(profile)]


def motion(params: Mapping[str, Any], prefix: str) -> SpeedProfile | PhasedProfile:
    """``prefix``'s motion from t = 0 (``scenario_lib.phases.profile_of``), its numbers checked."""
    for key in (f"{prefix}_speed_ms", f"{prefix}_end_speed_ms", "duration_s",
                "maneuver_start_s"):
        number(params, key)
    if params.get(f"{prefix}_phases") is not None:
        phases(params, prefix)
    return profile_of(params, prefix)


def npc_lane_change(params: Mapping[str, Any]) -> StoryEvent:
    """The NPC changes one lane toward ``lane_change_direction`` (cut-in or cut-out)."""
    return lane_change("npc", params["lane_change_direction"], number(params, "npc_speed_ms"),
                       number(params, "npc_end_speed_ms"), *manoeuvre_timing(params),
                       _phased_length(params, "npc"))


def hero_lane_change(params: Mapping[str, Any]) -> StoryEvent:
    """The ego changes one lane toward ``lane_change_direction``."""
    return lane_change(HERO, params["lane_change_direction"], number(params, "ego_speed_ms"),
                       number(params, "ego_end_speed_ms"), *manoeuvre_timing(params),
                       _phased_length(params, "ego"))


def _phased_length(params: Mapping[str, Any], prefix: str) -> float | None:
    """The lane change's length when ``prefix`` drives phases (None: the single ramp's)."""
    if params.get(f"{prefix}_phases") is None:
        return None
    motion(params, prefix)
    return lane_change_length(params, prefix)


# --- storyboards shared by several classes ---------------------------------------------------

def npc_lane_change_story(params: Mapping[str, Any],
                          hero_event: list[StoryEvent] | None = None) -> list[StoryEvent]:
    """Cut-in and cut-out: at the recorded gap the NPC changes one lane toward
    ``lane_change_direction`` and changes its speed; the ego drives its recorded speed profile
    (or ``hero_event``, e.g. its reaction to a slower cutter)."""
    change = recorded_lane_change_events(params, "npc", "npc") or [npc_lane_change(params)]
    return [*(hero_event or hero_speed_profile(params)), *change, *npc_speed_profile(params)]


def following_story(params: Mapping[str, Any]) -> list[StoryEvent]:
    """Car following (ahead or behind, one lane): both cars drive their recorded speed profiles,
    and the one behind keeps its distance once the record ends."""
    return [*hero_speed_profile(params), *npc_speed_profile(params),
            *keep_distance_after_record(params)]


def ego_lane_change_story(params: Mapping[str, Any]) -> list[StoryEvent]:
    """The ego changes one lane toward ``lane_change_direction`` and drives its speed profile."""
    change = recorded_lane_change_events(params, HERO, "ego") or [hero_lane_change(params)]
    return [*change, *hero_speed_profile(params)]


def hero_reacts_to_braking_lead(params: Mapping[str, Any]) -> list[StoryEvent]:
    """The ego's speed change when the lead brakes: as recorded, unless the lead ends slower.

    Then the ego slows to the lead's end speed, ``REACTION_TIME_S`` after the lead starts
    braking, over the lead's braking time or faster if that is needed to keep its distance
    (``scenario_lib.kinematics.ego_reaction``): an ego holding its speed would run into the lead.
    """
    return _hero_reacts_to_npc(params, cut_in=False)


def hero_reacts_to_cut_in(params: Mapping[str, Any]) -> list[StoryEvent]:
    """The ego's speed change when a car cuts in ahead: as recorded, unless the cutter ends
    slower; then the same reaction as behind a braking lead, keeping its distance from the
    moment the cutter starts to change into the ego's lane."""
    return _hero_reacts_to_npc(params, cut_in=True)


def _hero_reacts_to_npc(params: Mapping[str, Any], cut_in: bool) -> list[StoryEvent]:
    if params.get("ego_phases") is not None and not is_single_ramp(params, "ego"):
        # a recorded speed curve: what the ego did, then it keeps its distance
        return [*hero_speed_profile(params), *keep_distance_after_record(params)]
    start = number(params, "maneuver_start_s")
    ego_speed, lead_speed = number(params, "ego_speed_ms"), number(params, "npc_speed_ms")
    lead = motion(params, "npc")
    gap = start_gap_m(number(params, "npc_distance_m"), lead_speed, ego_speed, start)
    clearance = clearance_m(params.get("npc_vehicle_type"))
    reaction = lead_reaction(ego_speed, number(params, "ego_end_speed_ms"), lead, gap,
                             number(params, "timeout_s"), clearance, cut_in)
    return hero_speed_profile(params) if reaction is None else \
        [_profile_change(HERO, reaction)]


def stop_line_m(params: Mapping[str, Any]) -> float:
    """Distance from the ego's spawn to the stop line of the junction ahead."""
    return number(params, "spawn_stop_line_distance_m")


def hero_stops_at_line(params: Mapping[str, Any]) -> StoryEvent:
    """The ego brakes to 0 within ``brake_time_s`` and comes to rest before the stop line."""
    return _profile_change(HERO, stop_at_line(number(params, "ego_speed_ms"),
                                              number(params, "brake_time_s"), stop_line_m(params)))


def drive_to(entity: str, key: str, position: Any, start_s: float) -> StoryEvent:
    """``entity`` drives along the road network to ``position`` (AcquirePositionAction)."""
    return story_event(entity, key, xosc.AcquirePositionAction(position), start_s)


def right_turn_target(params: Mapping[str, Any]) -> xosc.WorldPosition:
    """Where the right turn ends: in the lane the junction's right movement leads to, as the
    spawn stage found it on the map (``turn_exit_*``)."""
    return world_position(params, "turn_exit")


def traffic_light(params: Mapping[str, Any], key: str, state: str, at_s: float) -> StoryEvent:
    """The controlling light (``pos=`` from ``tfl_x_carla/tfl_y_carla``) shows ``state``."""
    name = f"pos={number(params, 'tfl_x_carla'):.3f},{number(params, 'tfl_y_carla'):.3f}"
    action = xosc.TrafficSignalStateAction(name, LIGHT_STATES[state])
    return story_event("traffic_light", f"traffic_light_{key}", action, at_s)


def light_turns_red(params: Mapping[str, Any], yellow_s: float) -> list[StoryEvent]:
    """Yellow at ``yellow_s``, red ``YELLOW_PHASE_S`` later."""
    finite("the time the light turns yellow", yellow_s)
    return [traffic_light(params, "yellow", "yellow", yellow_s),
            traffic_light(params, "red", "red", yellow_s + YELLOW_PHASE_S)]


def red_light_for_stop(params: Mapping[str, Any]) -> list[StoryEvent]:
    """A stop at red: green (or already yellow when the ego must brake at once), yellow a
    reaction time before the ego starts braking, red ``YELLOW_PHASE_S`` later."""
    stop = stop_at_line(number(params, "ego_speed_ms"), number(params, "brake_time_s"),
                        stop_line_m(params))
    initial, yellow_s = red_light_timing(stop)
    return [traffic_light(params, "initial", initial, 0.0), *light_turns_red(params, yellow_s)]


def orange_light_for_pass(params: Mapping[str, Any]) -> list[StoryEvent]:
    """A pass on orange: yellow as the ego is 5 m before the stop line, then red."""
    ego = motion(params, "ego")
    return light_turns_red(params, orange_light_yellow_s(ego, stop_line_m(params)))


# --- the scenario ----------------------------------------------------------------------------

def _environment(weather_key: str) -> xosc.EnvironmentAction:
    weather = WEATHERS.get(weather_key)
    if weather is None:
        raise ValueError(f"weather_key must be one of {sorted(WEATHERS)}, not {weather_key!r}")
    rain = (xosc.PrecipitationType.rain if weather.rain_intensity else xosc.PrecipitationType.dry)
    environment = xosc.Environment(
        weather_key,
        xosc.TimeOfDay(False, HEADER_DATE.year, HEADER_DATE.month, HEADER_DATE.day,
                       weather.hour, 0, 0),
        xosc.Weather(weather.clouds, sun=xosc.Sun(weather.sun_intensity, 1.0,
                                                  weather.sun_elevation_rad),
                     fog=xosc.Fog(weather.visual_range_m), precipitation=xosc.Precipitation(
                         rain, weather.rain_intensity)),
        xosc.RoadCondition(1.0),
    )
    return xosc.EnvironmentAction(environment)


def _init(actors: list[Actor], weather_key: str) -> xosc.Init:
    init = xosc.Init()
    init.add_global_action(_environment(weather_key))
    start = xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0)
    for actor in actors:
        init.add_init_action(actor.name, xosc.TeleportAction(actor.position))
        init.add_init_action(actor.name, xosc.AbsoluteSpeedAction(actor.speed_ms, start))
    return init


def _flat(events: Iterable[object]) -> Iterator[StoryEvent]:
    """The events in order, a speed profile's list of phases (``hero_speed_profile``...)
    standing for its events; anything else is a TypeError saying what is expected (the
    scripts are written by an LLM too)."""
    for item in events:
        inner = [item] if isinstance(item, StoryEvent) else item
        if not isinstance(inner, list | tuple) or not all(isinstance(e, StoryEvent) for e in inner):
            raise TypeError("make_scenario: events are StoryEvents or lists of them (a speed "
                            f"profile's phases), not {item!r}")
        yield from inner


def _act(tag: str, events: Iterable[object], timeout_s: float) -> xosc.Act:
    # scenario_runner reads only criteria_* conditions from the Storyboard StopTrigger and ends
    # a scenario through its Acts, so the timeout is stated on the Act as well
    act = xosc.Act(f"{tag}_act", at_time("act_start", 0), at_time("act_stop", timeout_s, "stop"))
    maneuvers: dict[str, xosc.Maneuver] = {}
    for item in _flat(events):
        if item.group not in maneuvers:
            maneuvers[item.group] = xosc.Maneuver(f"{item.group}_maneuver")
            group = xosc.ManeuverGroup(f"{item.group}_group")
            group.add_actor(HERO if item.group == "traffic_light" else item.group)
            group.add_maneuver(maneuvers[item.group])
            act.add_maneuver_group(group)
        maneuvers[item.group].add_event(item.event)
    return act


def make_scenario(params: Mapping[str, Any], tag: str, actors: list[Actor],
                  events: Iterable[object]) -> xosc.Scenario:
    """The OpenSCENARIO 1.0 scenario for the CARLA map ``params["map"]`` (default Town04):
    entities, Init, one Story, stop trigger.

    ``tag`` is the script's corpus tag (names the Story and Act); ``actors`` start where and
    as fast as given, ``events`` (each a StoryEvent or a list of them, as a speed profile's
    phases come) run in the order given within their entity's ManeuverGroup,
    and the scenario stops at ``timeout_s``. Background traffic the params name
    (``background_traffic``) joins the actors.
    """
    actors = [*actors, *background_traffic(params)]
    entities = xosc.Entities()
    for actor in actors:
        entities.add_scenario_object(actor.name, _vehicle(actor))
    story = xosc.Story(f"{tag}_story", xosc.ParameterDeclarations())
    timeout_s = number(params, "timeout_s")
    story.add_act(_act(tag, events, timeout_s))
    storyboard = xosc.StoryBoard(_init(actors, params["weather_key"]),
                                 at_time("timeout", timeout_s, "stop"))
    storyboard.add_story(story)
    road_network = xosc.RoadNetwork(params.get("map") or MAP_NAME)
    return xosc.Scenario(
        f"ScenWeave {params['maneuver_class']} {params['scenario_id']}", AUTHOR,
        xosc.ParameterDeclarations(), entities, storyboard, road_network,
        xosc.Catalog(), osc_minor_version=0, creation_date=HEADER_DATE,
    )


def write_scenario(scenario: xosc.Scenario, out_path: str | os.PathLike[str]) -> Path:
    """Write ``scenario`` to ``out_path`` atomically (temp file in the same folder, replace)."""
    path = Path(out_path)
    path.parent.mkdir(parents=True, exist_ok=True)
    element = scenario.get_element()
    ET.indent(element, space="  ")
    # serialising to str and encoding once is ~2x faster than ET's utf-8 stream writer
    data = (XML_DECLARATION + ET.tostring(element, encoding="unicode")).encode("utf-8")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.chmod(tmp, _readable_mode())  # as scenweave.files does: mkstemp's 0600 hides it
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _readable_mode() -> int:
    """0o666 less the umask: the mode a plain ``open(path, "w")`` gives a new file."""
    umask = os.umask(0o022)
    os.umask(umask)
    return 0o666 & ~umask

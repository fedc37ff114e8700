"""Structural checks (thesis Table 5.8), manoeuvre semantics for both domains.

Every check reads one :class:`ScenarioDoc` and returns findings; ``maneuver_class`` and
``params`` are optional (without them class semantics are skipped).
"""

from __future__ import annotations

import math
import re

from lxml import etree

from scenweave import maneuvers
from scenweave.judge.fidelity import SPEED_TOL_MS
from scenweave.judge.findings import Finding
from scenweave.judge.scenario_doc import ScenarioDoc, number, source_line
from scenweave.maneuvers import Maneuver
from scenweave.scenario_lib.kinematics import SpeedProfile, min_gap_m, start_gap_m
from scenweave.scenario_lib.phases import PhasedProfile
from scenweave.schemas.params import Params, actor_value, all_finite

#: spawn coordinates of the thesis's examples (Appendix D) that an LLM may copy verbatim
DEFAULT_SPAWNS = ((312.4, 171.8), (312.4, -171.8), (-22.1, -18.9), (-22.1, 18.9))
STOPPING_LIGHT_STATES = {"yellow", "orange", "red"}
LIGHT_NAME = re.compile(r"^pos=(-?\d+(\.\d+)?),(-?\d+(\.\d+)?)$")
SPEED_TOLERANCE = 1e-6
TURN_HEADING_TOL_DEG = 45.0


def detect_domain(doc: ScenarioDoc) -> str:
    """Highway when the ego spawns on a LanePosition, else urban (thesis §5.4)."""
    position = doc.spawn_position(doc.ego_name) if doc.ego_name else None
    return "highway" if position is not None and position.tag == "LanePosition" else "urban"


def structural(doc: ScenarioDoc, domain: str, maneuver_class: str | None) -> list[Finding]:
    """The Table 5.8 checks."""
    root = doc.root
    if root.tag != "OpenSCENARIO":
        return [Finding("NO_ROOT", f"root element is <{root.tag}>, not <OpenSCENARIO>", "error",
                        source_line(root))]
    found: list[Finding] = []
    if root.find(".//Story") is None:
        found.append(Finding("NO_STORY", "no <Story> in the Storyboard", "error"))
    if root.find(".//ManeuverGroup") is None:
        found.append(Finding("NO_MANEUVER", "no <ManeuverGroup>", "error"))
    if root.find(".//StartTrigger") is None:
        found.append(Finding("NO_TRIGGER", "no <StartTrigger>", "error"))
    found += _ego_spawn(doc, domain)
    found += _speeds(doc, domain)
    found += _delays(doc)
    found += _overwrites(doc)
    if domain == "highway":
        groups = root.findall(".//ManeuverGroup")
        if len(groups) > 1 and len(doc.entities) < 2:
            found.append(Finding("NPC_MISSING", f"{len(groups)} ManeuverGroups but only one "
                                 "ScenarioObject", "error", source_line(groups[1])))
    elif _meets_a_light(maneuver_class) and root.find(".//TrafficSignalStateAction") is None:
        found.append(Finding("NO_TFL_ACTION", "urban scenario without TrafficSignalStateAction",
                             "error"))
    return found


def _ego_spawn(doc: ScenarioDoc, domain: str) -> list[Finding]:
    position = doc.spawn_position(doc.ego_name) if doc.ego_name is not None else None
    if position is None:
        return [Finding("NO_TELEPORT", "the ego (hero) has no TeleportAction in Init: it is "
                        "never spawned", "error")]
    if domain == "highway":
        if position.tag != "LanePosition":
            return [Finding("NO_LANEPOS", f"highway ego spawns on <{position.tag}>, expected "
                            "<LanePosition>", "error", source_line(position))]
        return []
    if position.tag != "WorldPosition":
        return [Finding("NO_WORLDPOS", f"urban ego spawns on <{position.tag}>, expected "
                        "<WorldPosition>", "error", source_line(position))]
    x, y = number(position, "x") or 0.0, number(position, "y") or 0.0
    if abs(x) < 1e-6 and abs(y) < 1e-6:
        return [Finding("ZERO_SPAWN", "ego WorldPosition is the origin (0, 0)", "error",
                        source_line(position))]
    if any(abs(x - dx) < 0.05 and abs(y - dy) < 0.05 for dx, dy in DEFAULT_SPAWNS):
        return [Finding("DEFAULT_SPAWN", f"ego WorldPosition ({x}, {y}) is a template default, "
                        "not a matched spawn point", "error", source_line(position))]
    return []


def _speeds(doc: ScenarioDoc, domain: str) -> list[Finding]:
    found = []
    if domain == "highway" and doc.root.find(".//AbsoluteTargetSpeed") is None:
        found.append(Finding("NO_SPEED_ACTION", "no SpeedAction with an AbsoluteTargetSpeed",
                             "error"))
    for entity in doc.entities:
        speed = doc.init_speed(entity)
        # a start from standstill is a valid record (issue 22), and so is another car standing
        # all along (a queue beside the ego); an ego that never moves is no manoeuvre (an
        # NPC's speeds are held to the record by parameter fidelity)
        never_moves = speed is not None and speed <= 0 and entity == "hero" \
            and not _moves_later(doc, entity)
        if speed is not None and (speed < 0 or never_moves):
            private = doc.init_private(entity)
            found.append(Finding("ZERO_SPEED", f"initial speed of {entity} is {speed} m/s"
                                 + ("" if speed < 0 else " and no speed action moves it"),
                                 "error", source_line(private)))
    return found


def _moves_later(doc: ScenarioDoc, entity: str) -> bool:
    """Whether a story speed action gives ``entity`` a target speed above 0."""
    for event in doc.events.values():
        target = event.action.find(".//AbsoluteTargetSpeed")
        if entity in event.actors and (number(target, "value") or 0.0) > 0:
            return True
    return False


def _delays(doc: ScenarioDoc) -> list[Finding]:
    found = []
    for condition in doc.all("Condition"):
        delay = condition.get("delay")
        if delay is None:
            continue
        if delay.startswith("$"):
            found.append(Finding("DELAY_PARAM", f"delay={delay!r} is an unresolved parameter",
                                 "error", source_line(condition)))
            continue
        try:
            float(delay)
        except ValueError:
            found.append(Finding("DELAY_EXPR", f"delay={delay!r} is an expression, not a number",
                                 "error", source_line(condition)))
    return found


def _overwrites(doc: ScenarioDoc) -> list[Finding]:
    """Events of one Maneuver starting together, one with priority overwrite: under
    OpenSCENARIO 1.0 starting it ends the other (CARLA happens to run both)."""
    found = []
    for maneuver in doc.root.iter("Maneuver"):
        starts: dict[float | None, list[etree._Element]] = {}
        for event in maneuver.findall("Event"):
            starts.setdefault(doc.event_start(event), []).append(event)
        for start, events in starts.items():
            overwriting = [e for e in events if e.get("priority") == "overwrite"]
            if start is not None and len(events) > 1 and overwriting:
                found.append(Finding(
                    "SEM_OVERWRITE", f"event {overwriting[0].get('name')!r} starts at {start} s "
                    f"with priority overwrite alongside {len(events) - 1} other event(s) of "
                    f"Maneuver {maneuver.get('name')!r}: it ends them (use parallel)",
                    line=source_line(overwriting[0])))
    return found


def _meets_a_light(maneuver_class: str | None) -> bool:
    maneuver = maneuvers.find(maneuver_class)
    return maneuver is None or maneuver.light is not None


# -- manoeuvre semantics --------------------------------------------------------------------

def semantics(doc: ScenarioDoc, maneuver_class: str | None,
              params: Params | None) -> list[Finding]:
    """What a scenario of this class must (not) contain (its :class:`Maneuver` says); empty
    when the class is unknown."""
    maneuver = maneuvers.find(maneuver_class)
    if maneuver is None:
        return []
    if maneuver.domain == "urban":
        return _urban_semantics(doc, maneuver, params)
    return _highway_semantics(doc, maneuver, params)


def _lane_changes(doc: ScenarioDoc) -> list[tuple[etree._Element, tuple[str, ...]]]:
    return [(e.action, e.actors) for e in doc.events.values()
            if e.action.find(".//LaneChangeAction") is not None]


def _highway_semantics(doc: ScenarioDoc, maneuver: Maneuver,
                       params: Params | None) -> list[Finding]:
    code = maneuver.code
    found = []
    ego = doc.ego_name
    others = [e for e in doc.entities if e != ego]
    if maneuver.npc_speed_change and not others:
        found.append(Finding("SEM_NO_NPC", f"{code} needs an NPC, the scenario has only the ego"))
    changes = _lane_changes(doc)
    if maneuver.lane_change is not None:
        wanted = ego if maneuver.lane_change == "hero" else None
        if not any((ego in actors) == (wanted == ego) for _, actors in changes):
            who = "the ego" if wanted else "the NPC"
            found.append(Finding("SEM_NO_LANE_CHANGE", f"{code} needs a LaneChangeAction of {who}"))
    elif changes:
        found.append(Finding("SEM_UNEXPECTED_LANE_CHANGE",
                             f"{code} has no lane change, the scenario has one",
                             line=source_line(changes[0][0])))
    if maneuver.lead_brakes and others:
        braking = params is None or params.get("npc_end_speed_ms", 0) < params.get(
            "npc_speed_ms", 0) - SPEED_TOLERANCE
        if braking and not _slows_down(doc, others):
            found.append(Finding("SEM_NO_BRAKE", f"{code}: no NPC SpeedAction slows the lead down"))
    if maneuver.ego_reacts is not None and params and "npc" in others:
        found += _rear_end(doc, maneuver, params)
    if maneuver.lane_change == "npc" and params:
        found += _cut_lanes(doc, maneuver, params)
    return found


def _rear_end(doc: ScenarioDoc, maneuver: Maneuver, params: Params) -> list[Finding]:
    """The ego must not run into the NPC in front: a braking lead (from t = 0) or a cutter
    (from its cut-in on). Both speed profiles come from the file, the gap at t = 0 from where
    the file places the two cars (along the lane, :func:`_start_gap`).

    Skipped when the file's start speeds are not the params' (FIDELITY_SPEED reports that
    cause; a collision would only be its consequence).
    """
    ego, lead = doc.speed_profile("hero"), doc.speed_profile("npc")
    ego_length, lead_length = doc.vehicle_length("hero"), doc.vehicle_length("npc")
    gap = _start_gap(doc, params)
    timeout = doc.stop_time
    if ego is None or lead is None or gap is None or timeout is None or ego_length is None \
            or lead_length is None or _other_start_speeds(params, ego, lead):
        return []
    cut_in = maneuver.ego_reacts == "from_cut_in"
    change = doc.events.get("npc_lane_change")
    from_s = (change.start_s if change is not None else None) if cut_in else 0.0
    if from_s is None:
        return []
    closest = min_gap_m(lead, ego, gap, timeout, from_s)
    touching = (ego_length + lead_length) / 2
    if closest < touching:
        what = "the car that cut in ahead" if cut_in else "the braking lead"
        return [Finding("SEM_COLLISION", f"{maneuver.code}: the ego runs into {what}: their "
                        f"centres come {closest:.1f} m close, {touching:.1f} m is bumper to "
                        "bumper (the ego must slow down when the car ahead ends slower)")]
    return []


def _other_start_speeds(params: Params,
                        *profiles: SpeedProfile | PhasedProfile) -> bool:
    wanted = (params.get("ego_speed_ms"), params.get("npc_speed_ms"))
    return any(want is not None and abs(profile.v0 - want) > SPEED_TOL_MS
               for want, profile in zip(wanted, profiles, strict=True))


def _start_gap(doc: ScenarioDoc, params: Params) -> float | None:
    """Distance from the ego to the NPC at t = 0, as the file places them.

    Both on LanePositions of the scenario's map: measured along the NPC's lane from beside the ego
    (``roads.distance_along_lane``). Otherwise the params' start gap (the recorded gap
    minus the lead-in drift), corrected by how far a WorldPosition moves the NPC from its
    spawn along its heading.
    """
    keys = all_finite(params.get("npc_distance_m"), params.get("npc_speed_ms"),
                      params.get("ego_speed_ms"), params.get("maneuver_start_s"))
    if keys is None:
        return None
    along = doc.lane_gap("npc")
    if along is not None:
        return along
    gap = start_gap_m(*keys)
    position = doc.spawn_position("npc")
    spawn = all_finite(actor_value(params, "npc", "x"), actor_value(params, "npc", "y"),
                       actor_value(params, "npc", "h"))
    if position is None or position.tag != "WorldPosition" or spawn is None:
        return gap
    x, y, h = spawn
    moved = ((number(position, "x") or 0.0) - x) * math.cos(h) \
        + ((number(position, "y") or 0.0) - y) * math.sin(h)
    return gap + moved


def _cut_lanes(doc: ScenarioDoc, maneuver: Maneuver, params: Params) -> list[Finding]:
    """A cut-in starts in the lane next to the ego's and ends in it; a cut-out starts in it.

    The ego's lane is followed along the map (``roads.advance_along_lane``) to where the
    NPC stands, so a gap across a road boundary compares the right lane ids.
    """
    ego_road = actor_value(params, "ego", "road_id")
    npc_road = actor_value(params, "npc", "road_id")
    keys = all_finite(actor_value(params, "ego", "lane_id"), actor_value(params, "ego", "s"),
                      params.get("npc_distance_m"), actor_value(params, "npc", "lane_id"))
    change = doc.events.get("npc_lane_change")
    if change is None:
        return []
    target = number(change.action.find(".//RelativeTargetLane"), "value")
    if ego_road is None or npc_road is None or keys is None or target is None \
            or doc.map_path is None:
        return []
    ego_lane, ego_s, distance, npc_lane_number = keys
    from scenweave import roads  # here: the map loads once, and only for scenarios that need it

    try:
        road, lane, _ = roads.advance_along_lane(ego_road, int(ego_lane), ego_s, distance,
                                                 map_path=doc.map_path)
    except roads.RoadError:  # not a lane position of the map: nothing to compare with
        return []
    if str(road) != str(npc_road):
        return []
    npc_lane = int(npc_lane_number)
    ends_in = npc_lane + int(target) if npc_lane < 0 else npc_lane - int(target)
    code, cut_in = maneuver.code, maneuver.npc_ends_in_ego_lane
    if cut_in and (npc_lane == lane or ends_in != lane):
        return [Finding("SEM_CUT_IN_LANE", f"{code}: the NPC starts in lane {npc_lane} and "
                        f"changes to lane {ends_in}; the ego's lane there is {lane} (a cut-in "
                        "starts next to it and ends in it)", line=source_line(change.action))]
    if not cut_in and npc_lane != lane:
        return [Finding("SEM_CUT_OUT_LANE", f"{code}: the NPC starts in lane {npc_lane}, not "
                        f"in the ego's lane {lane} (a cut-out leaves the ego's lane)")]
    return []


def _slows_down(doc: ScenarioDoc, entities: list[str]) -> bool:
    for event in doc.events.values():
        target = number(event.action.find(".//SpeedActionTarget/AbsoluteTargetSpeed"), "value")
        for entity in event.actors:
            start = doc.init_speed(entity)
            if entity in entities and target is not None and start is not None and target < start:
                return True
    return False


def _light_events(doc: ScenarioDoc) -> list[tuple[float | None, etree._Element]]:
    lights = []
    for event in doc.events.values():
        for action in event.action.iter("TrafficSignalStateAction"):
            lights.append((event.start_s, action))
    for action in doc.root.findall("Storyboard/Init//TrafficSignalStateAction"):
        lights.append((0.0, action))
    return sorted(lights, key=lambda item: item[0] if item[0] is not None else math.inf)


def _urban_semantics(doc: ScenarioDoc, maneuver: Maneuver,
                     params: Params | None) -> list[Finding]:
    code = maneuver.code
    found = []
    lights = _light_events(doc)
    for _, action in lights:
        if not LIGHT_NAME.match(action.get("name") or ""):
            found.append(Finding("URB_LIGHT_NAME", f"TrafficSignalStateAction name "
                                 f"{action.get('name')!r} is not 'pos=x,y': the light cannot be "
                                 "tied to the map", line=source_line(action)))
    states = [(t, (a.get("state") or "").lower()) for t, a in lights]
    if maneuver.stops_at_line:
        if not any(s in STOPPING_LIGHT_STATES for _, s in states):
            found.append(Finding("URB_LIGHT_NOT_RED",
                                 f"{code}: the light never turns yellow or red"))
        if not _ego_stops(doc):
            found.append(Finding("URB_NO_STOP",
                                 f"{code}: no SpeedAction brings the ego to 0 m/s"))
        else:
            found += _stop(doc, states, params)
    passes = maneuver.light in ("green", "green_or_orange")
    if passes and states and states[0][1] != "green":
        found.append(Finding("URB_LIGHT_START", f"{code}: the light starts {states[0][1]!r}, "
                             "the ego passes on green"))
    if maneuver.light == "green" and any(s == "red" for _, s in states):
        found.append(Finding("URB_RED_ON_GREEN", f"{code}: a green-light class turns the light "
                             "red"))
    if maneuver.light == "green_or_orange" and params:
        found += _pass_timing(doc, states, params)
    if maneuver.turn == "right":
        found += _right_turn(doc, params)
    return found


def _code(params: Params | None) -> str:
    return str((params or {}).get("maneuver_class") or "the class")


def _ego_stops(doc: ScenarioDoc) -> bool:
    for event in doc.events.values():
        target = number(event.action.find(".//SpeedActionTarget/AbsoluteTargetSpeed"), "value")
        if doc.ego_name in event.actors and target is not None and target <= SPEED_TOLERANCE:
            return True
    return False


def _state_at(states: list[tuple[float | None, str]], t: float) -> str | None:
    """The light's state at time ``t`` (the last change at or before it)."""
    shown = [s for start, s in states if start is not None and start <= t]
    return shown[-1] if shown else None


def _stop(doc: ScenarioDoc, states: list[tuple[float | None, str]],
          params: Params | None) -> list[Finding]:
    """A class that stops at the line: the ego brakes only once the light is no longer green,
    and (with the spawn's stop line in params) comes to rest at or before the stop line."""
    code = _code(params)
    ego = doc.speed_profile(doc.ego_name) if doc.ego_name else None
    if ego is None:
        return []
    found = []
    braking = _state_at(states, ego.start_s + 1e-6)
    if braking == "green":
        found.append(Finding("URB_BRAKE_ON_GREEN", f"{code}: the ego starts braking at "
                             f"{ego.start_s:.2f} s while the light is still green"))
    stop_line = (params or {}).get("spawn_stop_line_distance_m")
    stopping = ego.distance(ego.end_s)
    if stop_line is not None and stopping > stop_line + 1e-3:
        found.append(Finding("URB_STOP_PAST_LINE", f"{code}: the ego comes to rest "
                             f"{stopping:.1f} m from its start, past the stop line "
                             f"{stop_line:.1f} m ahead"))
    return found


def _pass_timing(doc: ScenarioDoc, states: list[tuple[float | None, str]],
                 params: Params) -> list[Finding]:
    """A class that passes on green or orange: the ego crosses the stop line before the light
    is red; on an orange record, after it turned yellow (else it passes on green)."""
    code = _code(params)
    stop_line = params.get("spawn_stop_line_distance_m")
    ego = doc.speed_profile(doc.ego_name) if doc.ego_name else None
    if stop_line is None or ego is None:
        return []
    passes_at = ego.time_to_cover(stop_line)
    state = _state_at(states, passes_at)
    if state == "red":
        return [Finding("URB_RED_BEFORE_PASS", f"{code}: the light is red when the ego reaches "
                        f"the stop line ({passes_at:.2f} s)")]
    if params.get("tfl_state") == "orange" and state == "green":
        return [Finding("URB_PASS_ON_GREEN", f"{code}: the record passed on orange, but the light "
                        f"is still green when the ego reaches the stop line ({passes_at:.2f} s)")]
    return []


def _right_turn(doc: ScenarioDoc, params: Params | None) -> list[Finding]:
    """A right turn: the ego is routed somewhere. When params carry the map's exit of the right
    movement (``turn_exit_*``), FIDELITY_TURN compares the target with it: the approach may
    curve before the junction, so where the exit lies seen from the spawn says little.
    Without it, the target must lie on the ego's right, facing right (a right turn ends about
    90 degrees clockwise of the start) and, with the spawn's stop line in params, past that
    stop line: a point before it is reached without turning at all."""
    code = _code(params)
    ego = doc.ego_name
    spawn = doc.spawn_position(ego) if ego else None
    targets = [e.action.find(".//AcquirePositionAction/Position/WorldPosition")
               for e in doc.events.values() if ego in e.actors]
    targets = [t for t in targets if t is not None]
    if not targets or spawn is None or spawn.tag != "WorldPosition":
        return [Finding("URB_NO_TURN", f"{code}: no AcquirePositionAction takes the ego anywhere")]
    if params and actor_value(params, "turn_exit", "x") is not None:
        return []
    target = targets[0]
    h = number(spawn, "h") or 0.0
    dx = (number(target, "x") or 0.0) - (number(spawn, "x") or 0.0)
    dy = (number(target, "y") or 0.0) - (number(spawn, "y") or 0.0)
    if dx * math.sin(h) - dy * math.cos(h) <= 0:
        return [Finding("URB_TURN_NOT_RIGHT", f"{code}: the ego's target lies to the left of its "
                        "heading", line=source_line(target))]
    turn = math.degrees(math.remainder((number(target, "h") or 0.0) - h, math.tau))
    if not -90 - TURN_HEADING_TOL_DEG <= turn <= -90 + TURN_HEADING_TOL_DEG:
        return [Finding("URB_TURN_HEADING", f"{code}: the target heading is {turn:+.0f} degrees "
                        "from the ego's; a right turn ends near -90", line=source_line(target))]
    stop_line = (params or {}).get("spawn_stop_line_distance_m")
    ahead = dx * math.cos(h) + dy * math.sin(h)
    if stop_line is not None and ahead <= stop_line:
        return [Finding("URB_TURN_BEFORE_LINE", f"{code}: the target is {ahead:.1f} m ahead, "
                        f"before the stop line {stop_line:.1f} m ahead: the ego turns before "
                        "the junction", line=source_line(target))]
    return []

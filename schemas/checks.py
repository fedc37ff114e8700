"""Structural checks (thesis Table 5.8), manoeuvre semantics for both domains.

Every check reads one :class:`ScenarioDoc` and returns findings; ``maneuver_class`` and
``params`` are optional (without them class semantics are skipped).
"""

from __future__ import annotations

import math
import re

from lxml import etree

from schemas.findings import Finding
from schemas.scenario_doc import ScenarioDoc, number

#: spawn coordinates of the thesis's examples (Appendix D) that an LLM may copy verbatim
DEFAULT_SPAWNS = ((312.4, 171.8), (312.4, -171.8), (-22.1, -18.9), (-22.1, 18.9))
NPC_CLASSES = {"BRAKE", "BR_BK", "CINF", "CINB", "COUTF", "COUTB", "FLF", "FLB"}
NPC_LANE_CHANGE_CLASSES = {"CINF", "CINB", "COUTF", "COUTB"}
EGO_LANE_CHANGE_CLASSES = {"LCF", "LCB"}
LIGHT_NAME = re.compile(r"^pos=(-?\d+(\.\d+)?),(-?\d+(\.\d+)?)$")
SPEED_TOLERANCE = 1e-6


def line(element: etree._Element | None) -> int | None:
    return None if element is None else element.sourceline


def detect_domain(doc: ScenarioDoc) -> str:
    """Highway when the ego spawns on a LanePosition, else urban (thesis §5.4)."""
    position = doc.spawn_position(doc.ego_name) if doc.ego_name else None
    return "highway" if position is not None and position.tag == "LanePosition" else "urban"


def structural(doc: ScenarioDoc, domain: str, maneuver_class: str | None) -> list[Finding]:
    """The Table 5.8 checks."""
    root = doc.root
    if root.tag != "OpenSCENARIO":
        return [Finding("NO_ROOT", f"root element is <{root.tag}>, not <OpenSCENARIO>", "error",
                        line(root))]
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
    if domain == "highway":
        groups = root.findall(".//ManeuverGroup")
        if len(groups) > 1 and len(doc.entities) < 2:
            found.append(Finding("NPC_MISSING", f"{len(groups)} ManeuverGroups but only one "
                                 "ScenarioObject", "error", line(groups[1])))
    elif maneuver_class != "U1_1" and root.find(".//TrafficSignalStateAction") is None:
        found.append(Finding("NO_TFL_ACTION", "urban scenario without TrafficSignalStateAction",
                             "error"))
    return found


def _ego_spawn(doc: ScenarioDoc, domain: str) -> list[Finding]:
    ego = doc.ego_name
    if ego is None or doc.init_private(ego) is None or doc.spawn_position(ego) is None:
        return [Finding("NO_TELEPORT", "the ego (hero) has no TeleportAction in Init: it is "
                        "never spawned", "error")]
    position = doc.spawn_position(ego)
    if domain == "highway":
        if position.tag != "LanePosition":
            return [Finding("NO_LANEPOS", f"highway ego spawns on <{position.tag}>, expected "
                            "<LanePosition>", "error", line(position))]
        return []
    if position.tag != "WorldPosition":
        return [Finding("NO_WORLDPOS", f"urban ego spawns on <{position.tag}>, expected "
                        "<WorldPosition>", "error", line(position))]
    x, y = number(position, "x") or 0.0, number(position, "y") or 0.0
    if abs(x) < 1e-6 and abs(y) < 1e-6:
        return [Finding("ZERO_SPAWN", "ego WorldPosition is the origin (0, 0)", "error",
                        line(position))]
    if any(abs(x - dx) < 0.05 and abs(y - dy) < 0.05 for dx, dy in DEFAULT_SPAWNS):
        return [Finding("DEFAULT_SPAWN", f"ego WorldPosition ({x}, {y}) is a template default, "
                        "not a matched spawn point", "error", line(position))]
    return []


def _speeds(doc: ScenarioDoc, domain: str) -> list[Finding]:
    found = []
    if domain == "highway" and doc.root.find(".//AbsoluteTargetSpeed") is None:
        found.append(Finding("NO_SPEED_ACTION", "no SpeedAction with an AbsoluteTargetSpeed",
                             "error"))
    for entity in doc.entities:
        speed = doc.init_speed(entity)
        if speed is not None and speed <= 0:
            private = doc.init_private(entity)
            found.append(Finding("ZERO_SPEED", f"initial speed of {entity} is {speed} m/s",
                                 "error", line(private)))
    return found


def _delays(doc: ScenarioDoc) -> list[Finding]:
    found = []
    for condition in doc.all("Condition"):
        delay = condition.get("delay")
        if delay is None:
            continue
        if delay.startswith("$"):
            found.append(Finding("DELAY_PARAM", f"delay={delay!r} is an unresolved parameter",
                                 "error", line(condition)))
            continue
        try:
            float(delay)
        except ValueError:
            found.append(Finding("DELAY_EXPR", f"delay={delay!r} is an expression, not a number",
                                 "error", line(condition)))
    return found


# -- manoeuvre semantics --------------------------------------------------------------------

def semantics(doc: ScenarioDoc, maneuver_class: str | None, params: dict | None) -> list[Finding]:
    """What a scenario of this class must (not) contain; empty when the class is unknown."""
    if not maneuver_class:
        return []
    if maneuver_class.startswith("U"):
        return _urban_semantics(doc, maneuver_class, params)
    return _highway_semantics(doc, maneuver_class, params)


def _lane_changes(doc: ScenarioDoc) -> list[tuple[etree._Element, tuple[str, ...]]]:
    return [(e.action, e.actors) for e in doc.events.values()
            if e.action.find(".//LaneChangeAction") is not None]


def _highway_semantics(doc: ScenarioDoc, code: str, params: dict | None) -> list[Finding]:
    found = []
    ego = doc.ego_name
    others = [e for e in doc.entities if e != ego]
    if code in NPC_CLASSES and not others:
        found.append(Finding("SEM_NO_NPC", f"{code} needs an NPC, the scenario has only the ego"))
    changes = _lane_changes(doc)
    if code in NPC_LANE_CHANGE_CLASSES | EGO_LANE_CHANGE_CLASSES:
        wanted = ego if code in EGO_LANE_CHANGE_CLASSES else None
        if not any((ego in actors) == (wanted == ego) for _, actors in changes):
            who = "the ego" if wanted else "the NPC"
            found.append(Finding("SEM_NO_LANE_CHANGE", f"{code} needs a LaneChangeAction of {who}"))
    elif changes:
        found.append(Finding("SEM_UNEXPECTED_LANE_CHANGE",
                             f"{code} has no lane change, the scenario has one",
                             line=line(changes[0][0])))
    if code in ("BRAKE", "BR_BK") and others:
        braking = params is None or params.get("npc_end_speed_ms", 0) < params.get(
            "npc_speed_ms", 0) - SPEED_TOLERANCE
        if braking and not _slows_down(doc, others):
            found.append(Finding("SEM_NO_BRAKE", f"{code}: no NPC SpeedAction slows the lead down"))
    return found


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


def _urban_semantics(doc: ScenarioDoc, code: str, params: dict | None) -> list[Finding]:
    found = []
    lights = _light_events(doc)
    for _, action in lights:
        if not LIGHT_NAME.match(action.get("name") or ""):
            found.append(Finding("URB_LIGHT_NAME", f"TrafficSignalStateAction name "
                                 f"{action.get('name')!r} is not 'pos=x,y': the light cannot be "
                                 "tied to the map", line=line(action)))
    states = [(t, (a.get("state") or "").lower()) for t, a in lights]
    if code == "U4_1":
        if not any(s in ("red", "yellow", "orange") for _, s in states):
            found.append(Finding("URB_LIGHT_NOT_RED", "U4_1: the light never turns yellow or red"))
        if not _ego_stops(doc):
            found.append(Finding("URB_NO_STOP", "U4_1: no SpeedAction brings the ego to 0 m/s"))
    if code in ("U4_2", "U4_3", "U4_4") and states and states[0][1] != "green":
        found.append(Finding("URB_LIGHT_START", f"{code}: the light starts {states[0][1]!r}, "
                             "the ego passes on green"))
    if code in ("U4_3", "U4_4") and any(s == "red" for _, s in states):
        found.append(Finding("URB_RED_ON_GREEN", f"{code}: a green-light class turns the light "
                             "red"))
    if code == "U4_2" and params:
        found += _red_before_pass(states, params)
    if code == "U4_4":
        found += _right_turn(doc)
    return found


def _ego_stops(doc: ScenarioDoc) -> bool:
    for event in doc.events.values():
        target = number(event.action.find(".//SpeedActionTarget/AbsoluteTargetSpeed"), "value")
        if doc.ego_name in event.actors and target is not None and target <= SPEED_TOLERANCE:
            return True
    return False


def _red_before_pass(states: list[tuple[float | None, str]], params: dict) -> list[Finding]:
    distance = params.get("spawn_stop_line_distance_m") or params.get("tfl_ds_m")
    speed = params.get("ego_speed_ms")
    if not distance or not speed:
        return []
    passes_at = distance / speed
    early = [t for t, s in states if s == "red" and t is not None and t < passes_at]
    if early:
        return [Finding("URB_RED_BEFORE_PASS", f"U4_2: the light turns red at {early[0]:.2f} s, "
                        f"before the ego reaches it ({passes_at:.2f} s)")]
    return []


def _right_turn(doc: ScenarioDoc) -> list[Finding]:
    ego = doc.ego_name
    spawn = doc.spawn_position(ego) if ego else None
    targets = [e.action.find(".//AcquirePositionAction/Position/WorldPosition")
               for e in doc.events.values() if ego in e.actors]
    targets = [t for t in targets if t is not None]
    if not targets or spawn is None or spawn.tag != "WorldPosition":
        return [Finding("URB_NO_TURN", "U4_4: no AcquirePositionAction takes the ego anywhere")]
    h = number(spawn, "h") or 0.0
    dx = (number(targets[0], "x") or 0.0) - (number(spawn, "x") or 0.0)
    dy = (number(targets[0], "y") or 0.0) - (number(spawn, "y") or 0.0)
    if dx * math.sin(h) - dy * math.cos(h) <= 0:
        return [Finding("URB_TURN_NOT_RIGHT", "U4_4: the ego's target lies to the left of its "
                        "heading", line=line(targets[0]))]
    return []

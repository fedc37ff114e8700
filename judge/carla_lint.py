"""CARLA compatibility: what scenario_runner can play from an OpenSCENARIO 1.0 file.

The action and condition sets follow scenario_runner's OpenSCENARIO support table; an
element outside them is parsed by scenario_runner but not executed (or rejected), so the
scenario would not do what it says.
"""

from __future__ import annotations

import re

from scenweave.judge.findings import Finding
from scenweave.judge.scenario_doc import ScenarioDoc, source_line

SUPPORTED_ACTIONS = {
    # PrivateAction
    "SpeedAction", "LongitudinalDistanceAction", "LaneChangeAction", "LaneOffsetAction",
    "TeleportAction", "AssignRouteAction", "AcquirePositionAction", "ActivateControllerAction",
    "AssignControllerAction",
    # GlobalAction / UserDefinedAction
    "EnvironmentAction", "AddEntityAction", "DeleteEntityAction", "ParameterSetAction",
    "ParameterModifyAction", "TrafficSignalStateAction", "TrafficSignalControllerAction",
    "CustomCommandAction",
}
UNSUPPORTED_ACTIONS = {
    "LateralDistanceAction", "SynchronizeAction", "VisibilityAction", "FollowTrajectoryAction",
    "OverrideThrottleAction", "OverrideBrakeAction", "OverrideClutchAction",
    "OverrideParkingBrakeAction", "OverrideSteeringWheelAction", "OverrideGearAction",
    "TrafficSourceAction", "TrafficSinkAction", "TrafficSwarmAction",
}
SUPPORTED_CONDITIONS = {
    "EndOfRoadCondition", "CollisionCondition", "OffroadCondition", "TimeHeadwayCondition",
    "TimeToCollisionCondition", "AccelerationCondition", "StandStillCondition",
    "SpeedCondition", "RelativeSpeedCondition", "TraveledDistanceCondition",
    "ReachPositionCondition", "DistanceCondition", "RelativeDistanceCondition",
    "ParameterCondition", "TimeOfDayCondition", "SimulationTimeCondition",
    "StoryboardElementStateCondition", "TrafficSignalCondition",
    "TrafficSignalControllerCondition",
}
UNSUPPORTED_CONDITIONS = {"UserDefinedValueCondition"}
CARLA_TOWN = re.compile(r"^(Town\d+[A-Za-z_]*|.*\.xodr)$")


def carla_lint(doc: ScenarioDoc) -> list[Finding]:
    """Findings for what CARLA's scenario_runner would not play as written."""
    found: list[Finding] = []
    header = doc.root.find("FileHeader")
    if header is not None and (header.get("revMajor"), header.get("revMinor")) != ("1", "0"):
        found.append(Finding("CARLA_VERSION", f"OpenSCENARIO {header.get('revMajor')}."
                             f"{header.get('revMinor')}: ScenWeave targets 1.0 for CARLA",
                             "error", source_line(header)))
    found += _ego(doc)
    for element in doc.root.iter():
        if element.tag in UNSUPPORTED_ACTIONS or element.tag in UNSUPPORTED_CONDITIONS:
            found.append(Finding("CARLA_UNSUPPORTED", f"<{element.tag}> is not supported by "
                                 "scenario_runner", "error", source_line(element)))
        elif element.tag == "CatalogReference":
            found.append(Finding("CARLA_CATALOG", "catalog references need CARLA's catalogs "
                                 "next to the file", "warning", source_line(element)))
    logic = doc.root.find("RoadNetwork/LogicFile")
    if logic is None or not CARLA_TOWN.match(logic.get("filepath") or ""):
        found.append(Finding("CARLA_MAP", "RoadNetwork/LogicFile should name a CARLA town "
                             "(e.g. Town04)", "warning", source_line(logic)))
    return found


def _ego(doc: ScenarioDoc) -> list[Finding]:
    found = []
    hero = doc.root.find("Entities/ScenarioObject[@name='hero']")
    if hero is None:
        return [Finding("CARLA_NO_HERO", "no ScenarioObject named 'hero': CARLA's agent has no "
                        "vehicle to drive", "error")]
    role = hero.find(".//Property[@name='type']")
    if role is None or role.get("value") != "ego_vehicle":
        found.append(Finding("CARLA_NO_HERO", "hero lacks Property type=ego_vehicle", "error",
                             source_line(hero)))
    for vehicle in doc.root.iter("Vehicle"):
        if not (vehicle.get("name") or "").startswith("vehicle."):
            found.append(Finding("CARLA_BLUEPRINT", f"vehicle {vehicle.get('name')!r} is not a "
                                 "CARLA blueprint (vehicle.*)", "warning", source_line(vehicle)))
    return found

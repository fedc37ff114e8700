"""CARLA compatibility: what scenario_runner can play from an OpenSCENARIO 1.0 file.

The action and condition sets follow scenario_runner's OpenSCENARIO support table; an
element outside them is parsed by scenario_runner but not executed (or rejected), so the
scenario would not do what it says.

``FollowTrajectoryAction`` is the one element the table and the parser disagree on: the
table marks it unsupported, while the parser (since its PR #751) takes it in the Story, not in
Init, with a ``Polyline`` shape (a Clothoid or a Nurbs raises), reading the vertex times and
leaving the following to the actor's controller, so CARLA follows the trajectory less tightly
than esmini's position mode. The lint says so (a ``CARLA_PARTIAL`` warning) for a Polyline in
the Story, which is how the in-situ scenario of a mined event replays its recorded traffic
(``scenweave export --for carla`` adds a client script that sets every transform per tick);
anywhere else the action is unsupported.
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
    "LateralDistanceAction", "SynchronizeAction", "VisibilityAction",
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
    found += _trajectories(doc)
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


#: the part of FollowTrajectoryAction scenario_runner's parser plays: a Polyline, in the Story
PARTIAL_ACTION = "FollowTrajectoryAction"
PLAYED_SHAPE = "Polyline"


def _trajectories(doc: ScenarioDoc) -> list[Finding]:
    """FollowTrajectoryAction: partly supported in the Story as a Polyline (one warning for
    all of them), unsupported in Init or with another shape (an error each)."""
    found, partial = [], []
    for action in doc.root.iter(PARTIAL_ACTION):
        shapes = [s.tag for s in action.iterfind(".//Trajectory/Shape/*")]
        in_init = any(a.tag == "Init" for a in action.iterancestors())
        if in_init or not shapes or any(tag != PLAYED_SHAPE for tag in shapes):
            where = "in Init" if in_init else f"with a {'/'.join(shapes) or 'missing'} shape"
            found.append(Finding("CARLA_UNSUPPORTED", f"<{PARTIAL_ACTION}> {where} is not "
                                 "supported by scenario_runner (only a Polyline in the Story)",
                                 "error", source_line(action)))
        else:
            partial.append(action)
    if partial:
        found.append(Finding(
            "CARLA_PARTIAL", f"{len(partial)} <{PARTIAL_ACTION}> (Polyline, in the Story): "
            "scenario_runner's parser plays them, its support table does not list them, and "
            "the following is left to each actor's controller, so CARLA follows less tightly "
            "than esmini; for a replay as recorded use the client script of `scenweave export "
            "--for carla` (it sets every transform per tick)", "warning",
            source_line(partial[0])))
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

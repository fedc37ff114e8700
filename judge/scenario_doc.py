"""A parsed scenario with the lookups the checks need (names per docs/scenario-conventions.md)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from lxml import etree

from scenweave.scenario_lib.kinematics import SpeedProfile
from scenweave.scenario_lib.phases import Phase, PhasedProfile

EGO_NAMES = ("hero", "ego")


@dataclass
class Event:
    """One storyboard event: its single action, the acting entities and its start time."""

    name: str
    action: etree._Element
    actors: tuple[str, ...]
    start_s: float | None


class ScenarioDoc:
    """Read-only views on one OpenSCENARIO tree.

    ``map_name`` is the map the scenario was made for (params ``map``); without it the map is
    the one ``RoadNetwork/LogicFile`` names (default Town04).
    """

    def __init__(self, tree: etree._ElementTree, map_name: str | None = None):
        self.tree = tree
        self.root = tree.getroot()
        self.map_name = map_name
        self._lane_gaps: dict[str, float | None] = {}

    def first(self, path: str) -> etree._Element | None:
        found = self.root.find(path)
        return found

    @cached_property
    def logic_file(self) -> str | None:
        """``RoadNetwork/LogicFile filepath``: the map the file names."""
        logic = self.root.find("RoadNetwork/LogicFile")
        return None if logic is None else logic.get("filepath")

    @cached_property
    def map_path(self) -> Path | None:
        """The OpenDRIVE file lane positions are read on (``roads.resolve_map`` of
        ``map_name`` or else ``logic_file``); None when that names no known map."""
        from scenweave import roads

        try:
            return roads.resolve_map(self.map_name or self.logic_file).path
        except roads.UnknownMapError:
            return None

    @cached_property
    def entities(self) -> list[str]:
        """The names of the ScenarioObjects, in file order ("" for one without a name, which
        the XSD check reports)."""
        return [e.get("name", "") for e in self.root.findall("Entities/ScenarioObject")]

    @cached_property
    def ego_name(self) -> str | None:
        return next((n for n in EGO_NAMES if n in self.entities), None)

    def init_private(self, entity: str) -> etree._Element | None:
        return self.root.find(f"Storyboard/Init/Actions/Private[@entityRef='{entity}']")

    def spawn_position(self, entity: str) -> etree._Element | None:
        """The Position element (LanePosition, WorldPosition, ...) of the entity's teleport."""
        private = self.init_private(entity)
        if private is None:
            return None
        position = private.find("PrivateAction/TeleportAction/Position")
        return position[0] if position is not None and len(position) else None

    def init_speed(self, entity: str) -> float | None:
        private = self.init_private(entity)
        target = None if private is None else private.find(
            "PrivateAction/LongitudinalAction/SpeedAction/SpeedActionTarget/AbsoluteTargetSpeed")
        return _number(target, "value")

    def vehicle_length(self, entity: str) -> float | None:
        """Length of the entity's bounding box (m)."""
        return _number(self.root.find(f"Entities/ScenarioObject[@name='{entity}']/Vehicle/"
                                      "BoundingBox/Dimensions"), "length")

    def speed_profile(self, entity: str) -> SpeedProfile | PhasedProfile | None:
        """The entity's start speed and its storyboard speed changes (time dynamics): one
        change as a ``SpeedProfile``, several (phases, a keep-distance after the record) as
        a ``PhasedProfile`` playing each in turn.

        None when it has no start speed; a profile that holds the start speed when no
        SpeedAction with ``time`` (or ``rate``) dynamics changes it.
        """
        v0 = self.init_speed(entity)
        if v0 is None:
            return None
        changes = []
        for event in self.events.values():
            target = _number(event.action.find(".//SpeedActionTarget/AbsoluteTargetSpeed"),
                             "value")
            dynamics = event.action.find(".//SpeedActionDynamics")
            value = _number(dynamics, "value")
            start = event.start_s
            if entity not in event.actors or dynamics is None or target is None \
                    or value is None or start is None:
                continue
            dimension = dynamics.get("dynamicsDimension")
            duration = value if dimension == "time" else abs(target - v0) / value \
                if dimension == "rate" and value > 0 else None
            if duration is not None:
                changes.append(SpeedProfile(v0, target, start, duration))
        if len(changes) > 1:  # a phased profile (corpus.phases): every change in turn
            return _chained(v0, sorted(changes, key=lambda c: c.start_s))
        return changes[0] if changes else SpeedProfile(v0, v0, 0, 0)

    def lane_gap(self, entity: str) -> float | None:
        """Metres along ``entity``'s lane from beside the ego to ``entity`` at t = 0.

        Both must stand on LanePositions of the scenario's map (``map_path``), the entity's
        lane must exist on the ego's road at the ego's ``s`` (beside it, or the ego's own lane)
        and lead to the entity within 1 km; otherwise ``None``. Measured once per entity (the
        map walk is the costly part of a check).
        """
        if entity not in self._lane_gaps:
            self._lane_gaps[entity] = self._measure_lane_gap(entity)
        return self._lane_gaps[entity]

    def _measure_lane_gap(self, entity: str) -> float | None:
        ego = self.spawn_position(self.ego_name) if self.ego_name else None
        other = self.spawn_position(entity)
        if ego is None or other is None or {ego.tag, other.tag} != {"LanePosition"}:
            return None
        ego_road, ego_s = ego.get("roadId"), _number(ego, "s")
        other_road, lane, other_s = other.get("roadId"), _number(other, "laneId"), \
            _number(other, "s")
        if ego_road is None or ego_s is None or other_road is None or lane is None \
                or other_s is None or self.map_path is None:
            return None
        from scenweave import roads  # here: the map loads once, only for scenarios needing it

        try:
            return roads.distance_along_lane(ego_road, int(lane), ego_s, other_road, int(lane),
                                             other_s, map_path=self.map_path)
        except roads.RoadError:  # not a lane position of the map
            return None

    @cached_property
    def events(self) -> dict[str, Event]:
        """Events by the name of their (single) action; unnamed actions by event name."""
        found: dict[str, Event] = {}
        for group in self.root.iter("ManeuverGroup"):
            actors = tuple(r.get("entityRef", "") for r in group.findall("Actors/EntityRef"))
            for event in group.iter("Event"):
                action = event.find("Action")
                if action is None:
                    continue
                key = action.get("name") or event.get("name") or ""
                found[key] = Event(key, action, actors, _start_time(event))
        return found

    @cached_property
    def stop_time(self) -> float | None:
        condition = self.root.find("Storyboard/StopTrigger//SimulationTimeCondition")
        return _number(condition, "value")

    @cached_property
    def weather_name(self) -> str | None:
        environment = self.root.find("Storyboard/Init/Actions/GlobalAction/EnvironmentAction/"
                                     "Environment")
        return None if environment is None else environment.get("name")

    @staticmethod
    def event_start(event: etree._Element) -> float | None:
        """Start time of an ``<Event>`` with a SimulationTimeCondition trigger."""
        return _start_time(event)

    def all(self, tag: str) -> list[etree._Element]:
        return list(self.root.iter(tag))


def _chained(v0: float, changes: list[SpeedProfile]) -> PhasedProfile:
    """Speed changes in start order as phases; one cut short by the next ends there (the
    next SpeedAction replaces it in the player)."""
    phases = []
    for change, following in zip(changes, [*changes[1:], None], strict=True):
        duration = max(change.duration_s, 0.0)
        if following is not None:
            duration = min(duration, following.start_s - change.start_s)
        phases.append(Phase(change.start_s, duration, change.end_speed))
    return PhasedProfile(v0, tuple(phases))


def _start_time(event: etree._Element) -> float | None:
    condition = event.find("StartTrigger/ConditionGroup/Condition/ByValueCondition/"
                           "SimulationTimeCondition")
    return _number(condition, "value")


def _number(element: etree._Element | None, attribute: str) -> float | None:
    text = None if element is None else element.get(attribute)
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return None


def source_line(element: etree._Element | None) -> int | None:
    """The line ``element`` starts on in the file (None without an element, or for one built
    in memory)."""
    if element is None:
        return None
    # lxml-stubs 0.5.1 declare ``sourceline = ...`` (so EllipsisType); lxml's is int | None
    line: int | None = element.sourceline  # type: ignore[assignment]
    return line


def number(element: etree._Element | None, attribute: str) -> float | None:
    """``float(element.attribute)`` or None when absent or not a number."""
    return _number(element, attribute)

"""What an in-situ scenario plays, read back from its folder: every vehicle's recorded
trajectory as the scenario states it, and where it is driven from outside.

The in-situ scenario (``scenario_lib.trajectories``) gives each vehicle a
``FollowTrajectoryAction`` with one ``Polyline`` vertex per recorded sample (time, world
position, heading) and its recorded size in its ``BoundingBox``; an externally driven hero
has no trajectory in the scenario, only its first pose in Init and its recorded trajectory
in ``hero_reference.csv`` beside it. Everything that shows or replays the scenario outside
esmini (the viewer's in-situ scene, the CARLA replay script of ``scenweave export --for
carla``) reads it through :func:`read_in_situ`, so they play what esmini plays.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lxml import etree

from scenweave.errors import InputError
from scenweave.judge.scenario_doc import number
from scenweave.schemas.scenario_folder import (
    HERO_REFERENCE_NAME,
    IN_SITU_CHOICE_NAME,
    IN_SITU_VERDICT_NAME,
    ROAD_NAME,
    VERDICT_NAME,
    XOSC_NAME,
    read_json_object,
)

#: the judge's numbers: the in-situ judge's verdict as ``mining.in_situ`` writes it, else a
#: replay verdict (the scenario-folder contract names both)
JUDGE_NAMES = (IN_SITU_VERDICT_NAME, VERDICT_NAME)


class InSituDocError(InputError, ValueError):
    """The folder is no in-situ scenario that can be read (one line naming file and
    element)."""


@dataclass(frozen=True)
class PlayedVehicle:
    """One vehicle of an in-situ scenario: its name, CARLA blueprint, size (m) and recorded
    trajectory (scenario times in s, box centre in the map's frame in m, heading in rad)."""

    name: str
    blueprint: str
    category: str
    length_m: float
    width_m: float
    height_m: float
    times: tuple[float, ...]
    x: tuple[float, ...]
    y: tuple[float, ...]
    heading: tuple[float, ...]
    #: driven by an external controller (the stack under test): the trajectory is its
    #: recorded reference, not what the scenario makes it do
    external: bool = False
    #: the recording's track id (the hero's ``track_id`` property; ``v<id>`` for the others)
    track_id: str | None = None

    @property
    def span(self) -> tuple[float, float]:
        """When the vehicle is on the road: its first and last recorded time (s)."""
        return self.times[0], self.times[-1]


@dataclass(frozen=True)
class InSituDoc:
    """An in-situ scenario: its road file (as the scenario names it), its duration and its
    vehicles in the scenario's order."""

    xosc: Path
    road_file: str
    duration_s: float
    vehicles: tuple[PlayedVehicle, ...]
    #: OpenDRIVE signal id -> its recorded colours as (from s, to s, state), from its
    #: TrafficSignalController's phases
    signals: dict[str, list[tuple[float, float, str]]]


def judge_numbers(folder: Path) -> dict[str, Any]:
    """The in-situ judge's verdict on the folder's replay (``{}``: not judged)."""
    for name in JUDGE_NAMES:
        data = read_json_object(Path(folder) / name)
        if isinstance(data.get("overall"), dict):
            return data
    return {}


def is_in_situ(folder: Path) -> bool:
    """Whether ``folder`` holds an in-situ scenario (its scenario beside its recorded road)."""
    return (folder / XOSC_NAME).is_file() and ((folder / IN_SITU_CHOICE_NAME).is_file()
                                               or (folder / ROAD_NAME).is_file())


def read_in_situ(folder: Path) -> InSituDoc:
    """The in-situ scenario in ``folder``; :class:`InSituDocError` naming the file and the
    element where it cannot be read."""
    xosc = Path(folder) / XOSC_NAME
    try:
        root = etree.parse(str(xosc)).getroot()
    except (OSError, etree.XMLSyntaxError) as err:
        raise InSituDocError(f"{xosc}: not readable: {err}") from err
    logic = root.find("RoadNetwork/LogicFile")
    stop = root.find(".//StopTrigger//SimulationTimeCondition")
    vehicles = tuple(_vehicle(xosc, root, item)
                     for item in root.iterfind("Entities/ScenarioObject"))
    if not vehicles:
        raise InSituDocError(f"{xosc}: no ScenarioObject")
    duration = number(stop, "value") if stop is not None else None
    return InSituDoc(xosc, logic.get("filepath", "") if logic is not None else "",
                     duration if duration is not None else max(v.times[-1] for v in vehicles),
                     vehicles, signal_spans(root))


def signal_spans(root: etree._Element) -> dict[str, list[tuple[float, float, str]]]:
    """Each signal's states from its controller's phases, laid end to end from t = 0."""
    spans: dict[str, list[tuple[float, float, str]]] = {}
    for controller in root.iterfind("RoadNetwork/TrafficSignals/TrafficSignalController"):
        now = 0.0
        for phase in controller.iterfind("Phase"):
            duration = number(phase, "duration") or 0.0
            for state in phase.iterfind("TrafficSignalState"):
                spans.setdefault(state.get("trafficSignalId") or "", []).append(
                    (now, now + duration, state.get("state") or "off"))
            now += duration
    return spans


def _vehicle(xosc: Path, root: etree._Element, item: etree._Element) -> PlayedVehicle:
    name = item.get("name") or ""
    vehicle = item.find("Vehicle")
    box = vehicle.find("BoundingBox/Dimensions") if vehicle is not None else None
    if vehicle is None or box is None:
        raise InSituDocError(f"{xosc}: ScenarioObject {name!r} has no Vehicle with a "
                             "BoundingBox")
    properties = {p.get("name"): p.get("value") for p in vehicle.iterfind("Properties/Property")}
    times, x, y, h = _polyline(xosc, root, name)
    external = not times
    if external:
        times, x, y, h = _reference(xosc.parent / HERO_REFERENCE_NAME, xosc, name)
    track = properties.get("track_id") or (name[1:] if name.startswith("v") else None)
    return PlayedVehicle(name, vehicle.get("name") or "", vehicle.get("vehicleCategory") or "car",
                         _positive(xosc, box, "length", name), _positive(xosc, box, "width", name),
                         _positive(xosc, box, "height", name), times, x, y, h, external, track)


def _positive(xosc: Path, box: etree._Element, what: str, name: str) -> float:
    value = number(box, what)
    if value is None or value <= 0:
        raise InSituDocError(f"{xosc}: {name}'s BoundingBox {what} is {box.get(what)!r}")
    return value


Samples = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]]


def _polyline(xosc: Path, root: etree._Element, name: str) -> Samples:
    """The vertices of ``name``'s FollowTrajectoryAction (empty: it has none)."""
    for group in root.iterfind(".//ManeuverGroup"):
        if group.find(f"Actors/EntityRef[@entityRef='{name}']") is None:
            continue
        rows = []
        for vertex in group.iterfind(".//FollowTrajectoryAction//Polyline/Vertex"):
            place = vertex.find("Position/WorldPosition")
            values = [number(vertex, "time"), *(number(place, k) for k in ("x", "y", "h"))] \
                if place is not None else [None]
            if any(v is None for v in values):
                raise InSituDocError(f"{xosc}: a Vertex of {name}'s trajectory (line "
                                     f"{vertex.sourceline}) lacks a time or a WorldPosition")
            rows.append(tuple(float(v) for v in values if v is not None))
        if rows:
            t, x, y, h = (tuple(column) for column in zip(*rows, strict=True))
            return t, x, y, h
    return (), (), (), ()


def _reference(path: Path, xosc: Path, name: str) -> Samples:
    """An externally driven vehicle's recorded reference (``t,x,y,h`` rows)."""
    try:
        with path.open(encoding="utf-8", newline="") as handle:
            rows = [tuple(float(row[k]) for k in ("t", "x", "y", "h"))
                    for row in csv.DictReader(handle)]
    except (OSError, KeyError, ValueError) as err:
        raise InSituDocError(f"{xosc}: {name} follows no trajectory and its reference "
                             f"{path.name} cannot be read: {err}") from err
    if len(rows) < 2:
        raise InSituDocError(f"{path}: {name}'s reference has {len(rows)} rows")
    t, x, y, h = (tuple(column) for column in zip(*rows, strict=True))
    return t, x, y, h

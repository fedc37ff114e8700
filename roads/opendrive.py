"""Reading an OpenDRIVE (``.xodr``) file into plain objects: roads, lanes, links, signals.

Only what placing vehicles exactly needs is read: plan view, elevation and superelevation,
lane offsets, lane sections with lane widths and links, road links, junction connections,
speed records (converted to km/h from the unit the file states), signals and signal
references. Lane ``<border>`` records are refused with a clear error rather than misread.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenweave.roads.errors import OpenDriveError
from scenweave.roads.plan_view import Arc, Geometry, Line, ParametricCubic, PlanView, Spiral

#: lane types a car may drive on (the one set: the player's map cutter asks it too)
DRIVABLE_LANE_TYPES = frozenset(
    {"driving", "entry", "exit", "onRamp", "offRamp", "connectingRamp", "bidirectional",
     "slipLane"})

#: factors from the speed units OpenDRIVE allows to km/h
SPEED_TO_KMH = {"km/h": 1.0, "m/s": 3.6, "mph": 1.609344}


class Poly3Track:
    """A piecewise cubic ``a + b ds + c ds^2 + d ds^3`` of ``s`` (elevation, widths, offsets)."""

    def __init__(self, starts: list[float], coefficients: list[tuple[float, float, float, float]]):
        order = np.argsort(starts, kind="stable")
        self.starts = np.asarray(starts, dtype=float)[order] if starts else np.zeros(1)
        self.coefficients = (np.asarray(coefficients, dtype=float)[order] if coefficients
                             else np.zeros((1, 4)))
        #: per-coefficient columns (a, b, c, d); most tracks (constant widths) have one piece
        self._columns = tuple(self.coefficients.T)

    def _pieces(self, s: np.ndarray) -> tuple[tuple[np.ndarray | float, ...], np.ndarray]:
        if len(self.starts) == 1:  # no lookup: this runs for every lane on every lane walk
            return tuple(float(column[0]) for column in self._columns), s - self.starts[0]
        index = np.clip(np.searchsorted(self.starts, s, side="right") - 1, 0, len(self.starts) - 1)
        return tuple(column[index] for column in self._columns), s - self.starts[index]

    def constant_on(self, low: float, high: float) -> float | None:
        """The track's value if it does not change anywhere on ``[low, high]``, else ``None``."""
        first, last = np.clip(np.searchsorted(self.starts, [low, high], side="right") - 1,
                              0, len(self.starts) - 1)
        pieces = self.coefficients[first:last + 1]
        if pieces[:, 1:].any() or (pieces[:, 0] != pieces[0, 0]).any():
            return None
        return float(pieces[0, 0])

    def value(self, s: np.ndarray | float) -> np.ndarray:
        """The polynomial's value at ``s``."""
        (a, b, c, d), ds = self._pieces(np.asarray(s, dtype=float))
        return a + ds * (b + ds * (c + ds * d))

    def slope(self, s: np.ndarray | float) -> np.ndarray:
        """The derivative with respect to ``s``."""
        (_, b, c, d), ds = self._pieces(np.asarray(s, dtype=float))
        return b + ds * (2 * c + 3 * d * ds)


@dataclass(frozen=True)
class Lane:
    """One lane of a lane section; ``width`` is a function of the road's ``s``."""

    id: int
    type: str
    width: Poly3Track
    predecessor: int | None
    successor: int | None

    @property
    def drivable(self) -> bool:
        """Whether a car may drive on this lane."""
        return self.type in DRIVABLE_LANE_TYPES


@dataclass(frozen=True)
class LaneSection:
    """Lanes valid from ``s_start`` to ``s_end`` of a road."""

    s_start: float
    s_end: float
    lanes: dict[int, Lane]


@dataclass(frozen=True)
class RoadLink:
    """Where a road continues: another road (with contact point) or a junction."""

    element_type: str
    element_id: str
    contact_point: str | None


@dataclass(frozen=True)
class Signal:
    """A ``<signal>`` (or, with ``reference_only``, a ``<signalReference>``) on a road."""

    id: str
    road_id: str
    s: float
    t: float
    dynamic: bool
    type: str
    name: str
    orientation: str
    z_offset: float
    valid_lanes: tuple[tuple[int, int], ...]
    reference_only: bool = False


@dataclass
class Road:
    """One ``<road>``."""

    id: str
    name: str
    length: float
    junction: str
    predecessor: RoadLink | None
    successor: RoadLink | None
    plan_view: PlanView
    elevation: Poly3Track
    superelevation: Poly3Track
    lane_offset: Poly3Track
    sections: list[LaneSection]
    speed_kmh: list[tuple[float, float]]
    signals: list[Signal] = field(default_factory=list)
    signal_references: list[Signal] = field(default_factory=list)

    @property
    def in_junction(self) -> bool:
        """Whether the road is a connecting road inside a junction."""
        return self.junction != "-1"

    def section_index(self, s: float, moving_forward: bool = True) -> int:
        """Index of the lane section holding ``s``; at a boundary, the one the car enters."""
        starts = [section.s_start for section in self.sections]
        index = int(np.searchsorted(starts, s, side="right")) - 1
        if not moving_forward and index > 0 and math.isclose(s, starts[index], abs_tol=1e-9):
            index -= 1
        return max(index, 0)

    def speed_limit_kmh(self, s: float) -> float | None:
        """The speed record in force at ``s`` (km/h), ``None`` if the road has none."""
        limit = None
        for start, value in self.speed_kmh:
            if start <= s + 1e-9:
                limit = value
        return limit


@dataclass(frozen=True)
class Connection:
    """A junction connection: lanes of ``incoming_road`` continue on ``connecting_road``."""

    id: str
    incoming_road: str
    connecting_road: str
    #: ``start`` or ``end`` of the connecting road; ``None`` when the file does not say
    contact_point: str | None
    lane_links: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class Junction:
    """A ``<junction>`` and its connections."""

    id: str
    connections: tuple[Connection, ...]


@dataclass
class OpenDriveMap:
    """A whole road network."""

    name: str
    roads: dict[str, Road]
    junctions: dict[str, Junction]

    def signal(self, signal_id: str) -> Signal:
        """The physical ``<signal>`` with this id (not a reference to it)."""
        for road in self.roads.values():
            for signal in road.signals:
                if signal.id == signal_id:
                    return signal
        raise OpenDriveError(f"{self.name}: no <signal id={signal_id!r}> in the map")


def load_opendrive(path: str | Path) -> OpenDriveMap:
    """Parse the OpenDRIVE file at ``path``."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as err:
        raise OpenDriveError(f"{path}: cannot read the OpenDRIVE file ({err})") from err
    if root.tag != "OpenDRIVE":
        raise OpenDriveError(f"{path}: root element is <{root.tag}>, expected <OpenDRIVE>")
    roads = {}
    for element in root.findall("road"):
        road = _read_road(element, path)
        roads[road.id] = road
    junctions = {}
    for element in root.findall("junction"):
        junction = _read_junction(element, f"{path.name}: junction {element.get('id')}")
        junctions[junction.id] = junction
    return OpenDriveMap(name=path.stem, roads=roads, junctions=junctions)


def _float(element: ET.Element, name: str, where: str, default: float | None = None) -> float:
    raw = element.get(name)
    if raw is None:
        if default is not None:
            return default
        raise OpenDriveError(f"{where}: <{element.tag}> has no attribute {name!r}")
    try:
        return float(raw)
    except ValueError as err:
        raise OpenDriveError(f"{where}: <{element.tag} {name}={raw!r}> is not a number") from err


def _text(element: ET.Element, name: str, where: str) -> str:
    raw = element.get(name)
    if raw is None:
        raise OpenDriveError(f"{where}: <{element.tag}> has no attribute {name!r}")
    return raw


def _int(element: ET.Element, name: str, where: str) -> int:
    raw = _text(element, name, where)
    try:
        return int(raw)
    except ValueError as err:
        raise OpenDriveError(f"{where}: <{element.tag} {name}={raw!r}> is not an integer") from err


def _cubic(element: ET.Element, names: tuple[str, str, str, str],
           where: str) -> tuple[float, float, float, float]:
    a, b, c, d = (_float(element, name, where) for name in names)
    return a, b, c, d


def _poly3_track(elements: list[ET.Element], where: str, start_attr: str = "s",
                 base: float = 0.0) -> Poly3Track:
    starts = [base + _float(e, start_attr, where) for e in elements]
    coefficients = [_cubic(e, ("a", "b", "c", "d"), where) for e in elements]
    return Poly3Track(starts, coefficients)


def _read_road(element: ET.Element, path: Path) -> Road:
    where = f"{path.name}: road {element.get('id')}"
    road_id = _text(element, "id", where)
    length = _float(element, "length", where)
    link = element.find("link")
    geometries = [_read_geometry(g, where) for g in element.findall("planView/geometry")]
    if not geometries:
        raise OpenDriveError(f"{where}: <planView> has no <geometry>")
    lanes = element.find("lanes")
    if lanes is None:
        raise OpenDriveError(f"{where}: no <lanes>")
    road = Road(
        id=road_id, name=element.get("name", ""), length=length,
        junction=element.get("junction", "-1"),
        predecessor=_read_link(link, "predecessor", where),
        successor=_read_link(link, "successor", where),
        plan_view=PlanView(geometries),
        elevation=_poly3_track(element.findall("elevationProfile/elevation"), where),
        superelevation=_poly3_track(element.findall("lateralProfile/superelevation"), where),
        lane_offset=_poly3_track(lanes.findall("laneOffset"), where),
        sections=_read_sections(lanes, length, where),
        speed_kmh=[_read_speed(t, where) for t in element.findall("type")
                   if t.find("speed") is not None],
    )
    for signal in element.findall("signals/signal"):
        road.signals.append(_read_signal(signal, road_id, where, reference_only=False))
    for reference in element.findall("signals/signalReference"):
        road.signal_references.append(_read_signal(reference, road_id, where, reference_only=True))
    return road


def _read_link(link: ET.Element | None, kind: str, where: str) -> RoadLink | None:
    target = None if link is None else link.find(kind)
    if target is None:
        return None
    return RoadLink(target.get("elementType", "road"), _text(target, "elementId", where),
                    target.get("contactPoint"))


def _read_geometry(element: ET.Element, where: str) -> Geometry:
    start = {k: _float(element, k, where) for k in ("s", "x", "y", "hdg", "length")}
    if not len(element):
        raise OpenDriveError(f"{where}: geometry at s={start['s']} has unknown kind <None>")
    kind = element[0]
    tag = kind.tag
    if tag == "line":
        return Line(**start)
    if tag == "arc":
        return Arc(**start, curvature=_float(kind, "curvature", where))
    if tag == "spiral":
        return Spiral(**start, curv_start=_float(kind, "curvStart", where),
                      curv_end=_float(kind, "curvEnd", where))
    if tag == "poly3":
        return ParametricCubic(**start, coeff_u=(0.0, 1.0, 0.0, 0.0),
                               coeff_v=_cubic(kind, ("a", "b", "c", "d"), where))
    if tag == "paramPoly3":
        normalized = kind.get("pRange", "normalized") == "normalized"
        return ParametricCubic(**start,
                               coeff_u=_cubic(kind, ("aU", "bU", "cU", "dU"), where),
                               coeff_v=_cubic(kind, ("aV", "bV", "cV", "dV"), where),
                               p_end=1.0 if normalized else start["length"])
    raise OpenDriveError(f"{where}: geometry at s={start['s']} has unknown kind <{tag}>")


def _read_sections(lanes: ET.Element, road_length: float, where: str) -> list[LaneSection]:
    elements = sorted(lanes.findall("laneSection"), key=lambda e: _float(e, "s", where))
    if not elements:
        raise OpenDriveError(f"{where}: <lanes> has no <laneSection>")
    sections = []
    for i, element in enumerate(elements):
        s_start = _float(element, "s", where)
        s_end = _float(elements[i + 1], "s", where) if i + 1 < len(elements) else road_length
        lanes_by_id = {}
        for lane in element.iter("lane"):
            lane_where = f"{where}, lane section s={s_start:g}, lane {lane.get('id')}"
            if lane.find("border") is not None:
                raise OpenDriveError(f"{lane_where}: <border> lane shapes are not supported; "
                                     "convert the map to <width> records")
            link = lane.find("link")
            lane_id = _int(lane, "id", lane_where)
            lanes_by_id[lane_id] = Lane(
                id=lane_id, type=lane.get("type", "none"),
                width=_poly3_track(lane.findall("width"), lane_where, "sOffset", s_start),
                predecessor=_lane_link(link, "predecessor", lane_where),
                successor=_lane_link(link, "successor", lane_where))
        sections.append(LaneSection(s_start, s_end, lanes_by_id))
    return sections


def _lane_link(link: ET.Element | None, kind: str, where: str) -> int | None:
    target = None if link is None else link.find(kind)
    return None if target is None else _int(target, "id", where)


def _read_speed(type_element: ET.Element, where: str) -> tuple[float, float]:
    speed = type_element.find("speed")
    if speed is None:
        raise OpenDriveError(f"{where}: <type> has no <speed>")
    unit = speed.get("unit", "m/s")
    if unit not in SPEED_TO_KMH:
        raise OpenDriveError(f"{where}: speed unit {unit!r} is not one of {sorted(SPEED_TO_KMH)}")
    return _float(type_element, "s", where), _float(speed, "max", where) * SPEED_TO_KMH[unit]


def _read_signal(element: ET.Element, road_id: str, where: str, reference_only: bool) -> Signal:
    validity = tuple((_int(v, "fromLane", where), _int(v, "toLane", where))
                     for v in element.findall("validity"))
    return Signal(
        id=_text(element, "id", where), road_id=road_id, s=_float(element, "s", where),
        t=_float(element, "t", where), dynamic=element.get("dynamic") == "yes",
        type=element.get("type", ""), name=element.get("name", ""),
        orientation=element.get("orientation", "none"),
        z_offset=_float(element, "zOffset", where, 0.0), valid_lanes=validity,
        reference_only=reference_only)


def _read_junction(element: ET.Element, where: str) -> Junction:
    connections = tuple(
        Connection(id=_text(c, "id", where), incoming_road=_text(c, "incomingRoad", where),
                   connecting_road=_text(c, "connectingRoad", where),
                   contact_point=c.get("contactPoint"),
                   lane_links=tuple((_int(ll, "from", where), _int(ll, "to", where))
                                    for ll in c.findall("laneLink")))
        for c in element.findall("connection"))
    return Junction(_text(element, "id", where), connections)

"""A recorded lane network (lanelets with their own borders, as CommonRoad or highD give them)
written as OpenDRIVE 1.4, so a recording can be played on the road it was recorded on.

The model is neutral: :class:`LaneStrip` (a lane piece with its left and right border in its
driving direction, its predecessors, successors and side neighbours) and
:class:`RecordedLight`. :func:`convert` makes the map; the conventions (docs/recorded-road.md):

- Laterally adjacent same-direction strips whose shared border coincides
  (:data:`SHARED_BORDER_M`) make one road, its lanes side by side (``-1`` leftmost); every
  other strip is a road of its own. A road's reference line is its leftmost strip's left
  border (``recorded_geometry.reference_pieces``: C1 ``paramPoly3`` pieces); ``laneOffset``
  and each lane's ``width`` records follow the strips' own borders within 1 cm, so a flaring
  lane flares in the map too. All lanes run in the road's direction (right lanes).
- Links: a road whose strips continue into exactly one road, which continues from nothing
  else, links to it directly. Where strips split or merge, the roads between the branching
  point and the next road become a junction's connecting roads (a junction per group of
  connectors sharing an incoming or outgoing road), and the roads around link to the junction.
- A light becomes one dynamic ``signal`` (type 1000001, no ``value``: esmini looks light types
  up as ``type[.subtype][-value]`` and aborts on an unknown one) per strip it governs, on that
  strip's road and lane at its stop line, ``s`` always within ``[0, length)`` (esmini aborts
  the whole process on a signal past its road's end).

Of ours only the error root is imported (numpy, SciPy and lxml besides); reading a format into
strips is the readers' job.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

from scenweave.roads.errors import RecordedRoadError
from scenweave.roads.recorded_geometry import (
    MIN_SPACING_M,
    DenseLine,
    Floats,
    Piece,
    lateral_profiles,
    linear_records,
    reference_pieces,
    stations,
    tangents,
    thinned,
)

#: bumped whenever the written map changes for the same input (cache keys include it)
CONVERTER_VERSION = "4"
#: a border shorter than this makes no lane (m); a short lanelet is fine (one piece)
MIN_BORDER_M = 0.01
#: two strips share a road where their common border differs by less than this (m)
SHARED_BORDER_M = 0.1
#: OpenDRIVE signal type of a traffic light (as CARLA and esmini read it)
TRAFFIC_LIGHT_TYPE = "1000001"
#: a reference line is extended where another border's end lies beyond its end by more (m)
EXTEND_MIN_M = 0.05
#: a signal stands at least this far inside its road's ends (m)
SIGNAL_MARGIN_M = 0.01


@dataclass(frozen=True)
class LaneStrip:
    """One lanelet: its borders in its driving direction (n x 2, m) and its neighbours."""

    id: str
    left: Floats
    right: Floats
    predecessors: tuple[str, ...] = ()
    successors: tuple[str, ...] = ()
    left_neighbour: str | None = None
    left_same_direction: bool = False
    right_neighbour: str | None = None
    right_same_direction: bool = False
    #: an OpenDRIVE lane type ("driving", "sidewalk", "biking"...)
    lane_type: str = "driving"

    @property
    def centre(self) -> Floats:
        """The centre line as CommonRoad defines it (midpoints of the border vertices, the
        borders resampled to a common count where they differ)."""
        n = max(len(self.left), len(self.right))
        return (_resampled(self.left, n) + _resampled(self.right, n)) / 2


@dataclass(frozen=True)
class RecordedLight:
    """A traffic light and the strips it governs, with each strip's stop line
    ``(strip, x0, y0, x1, y1)`` (missing: the strip's end)."""

    id: str
    strips: tuple[str, ...]
    position: tuple[float, float] | None = None
    stop_lines: tuple[tuple[str, float, float, float, float], ...] = ()


@dataclass(frozen=True)
class SignalPlacement:
    """Where one light's signal for one strip went."""

    signal_id: str
    light_id: str
    strip: str
    road_id: int
    lane_id: int
    s: float


@dataclass(frozen=True)
class ConvertedRoad:
    """The OpenDRIVE text and what a scenario needs to address it."""

    xodr: bytes
    #: strip id -> (road id, lane id)
    lanes: dict[str, tuple[int, int]]
    signals: tuple[SignalPlacement, ...] = ()
    #: road ids that are a junction's connecting roads
    junction_roads: frozenset[int] = frozenset()
    #: strip links the map could not express (a strip continuing into two roads that are no
    #: junction's connectors), as "from->to"
    unlinked: tuple[str, ...] = ()

    def signal_ids(self, light_id: str) -> tuple[str, ...]:
        """The OpenDRIVE signal ids standing for one recorded light."""
        return tuple(p.signal_id for p in self.signals if p.light_id == light_id)


def _resampled(polyline: Floats, n: int) -> Floats:
    """``n`` points evenly spaced along a polyline by arc length."""
    if len(polyline) == n:
        return np.asarray(polyline, dtype=float)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(polyline, axis=0).T))])
    at = np.linspace(0.0, along[-1], n)
    return np.column_stack([np.interp(at, along, polyline[:, 0]),
                            np.interp(at, along, polyline[:, 1])])


# --- roads from strips ----------------------------------------------------------------------

@dataclass
class _Road:
    """A road being built: its strips left to right, geometry and lane profiles."""

    id: int
    strips: list[LaneStrip]
    pieces: list[Piece] = field(default_factory=list)
    line: DenseLine | None = None
    stations: Floats = field(default_factory=lambda: np.zeros(0))
    #: t of each strip's left border, then of the rightmost strip's right border, at stations
    borders: list[Floats] = field(default_factory=list)
    junction: int = -1

    @property
    def length(self) -> float:
        return sum(p.length for p in self.pieces)

    def lane_id(self, strip_id: str) -> int:
        return -1 - next(k for k, s in enumerate(self.strips) if s.id == strip_id)

    def widths(self) -> list[Floats]:
        return [np.maximum(self.borders[k] - self.borders[k + 1], 0.0)
                for k in range(len(self.strips))]

    def lane_centre_t(self, lane_index: int, s: float) -> float:
        left = np.interp(s, self.stations, self.borders[lane_index])
        right = np.interp(s, self.stations, self.borders[lane_index + 1])
        return float(left + right) / 2


def check_strip(strip: LaneStrip) -> None:
    """Raise :class:`RecordedRoadError` naming the strip where its borders cannot make a lane."""
    for side, border in (("left", strip.left), ("right", strip.right)):
        border = np.asarray(border, dtype=float)
        if border.ndim != 2 or border.shape[1] != 2 or len(border) < 2:
            raise RecordedRoadError(f"lanelet {strip.id}: its {side} border has "
                                    f"{len(border)} points, not two or more (x, y)")
        if not np.isfinite(border).all():
            raise RecordedRoadError(f"lanelet {strip.id}: its {side} border holds NaN or "
                                    "infinite coordinates")
        length = float(np.hypot(*np.diff(border, axis=0).T).sum())
        if length < MIN_BORDER_M:
            raise RecordedRoadError(f"lanelet {strip.id}: its {side} border is {length:.3f} m "
                                    f"long, shorter than {MIN_BORDER_M} m")


def _shares_border(left: LaneStrip, right: LaneStrip) -> bool:
    """Whether ``right`` lies right beside ``left`` along the whole of their shared border."""
    a, b = np.asarray(left.right, float), np.asarray(right.left, float)
    return _hausdorff(a, b) < SHARED_BORDER_M


def _hausdorff(a: Floats, b: Floats) -> float:
    """Symmetric Hausdorff distance of two polylines (points to segments, both ways)."""
    def one_way(p: Floats, q: Floats) -> float:
        seg = np.diff(q, axis=0)
        rel = p[:, None, :] - q[None, :-1, :]
        u = np.clip((rel * seg[None]).sum(2) / np.maximum((seg ** 2).sum(1), 1e-12)[None], 0, 1)
        foot = q[None, :-1, :] + u[..., None] * seg[None]
        return float(np.sqrt(((p[:, None, :] - foot) ** 2).sum(2).min(axis=1)).max())
    return max(one_way(a, b), one_way(b, a))


def group_strips(strips: Sequence[LaneStrip]) -> list[list[LaneStrip]]:
    """Strips grouped into roads, each group left to right (see the module docstring)."""
    by_id = {s.id: s for s in strips}

    def right_of(strip: LaneStrip) -> LaneStrip | None:
        other = by_id.get(strip.right_neighbour or "")
        if other is None or not strip.right_same_direction or not _shares_border(strip, other):
            return None
        return other

    grouped_right = {r.id for s in strips if (r := right_of(s)) is not None}
    groups: list[list[LaneStrip]] = []
    taken: set[str] = set()
    for head in sorted(strips, key=lambda s: _id_key(s.id)):
        if head.id in grouped_right or head.id in taken:
            continue
        group, strip = [head], right_of(head)
        while strip is not None and strip.id not in taken and strip not in group:
            group.append(strip)
            strip = right_of(strip)
        taken.update(s.id for s in group)
        groups.append(group)
    # a ring of neighbours has no head: each left strip becomes a road of its own
    groups += [[s] for s in strips if s.id not in taken]
    return groups


def _id_key(strip_id: str) -> tuple[int, str]:
    return (int(strip_id), "") if strip_id.lstrip("-").isdigit() else (0, strip_id)


def extended_reference(strips: Sequence[LaneStrip]) -> Floats:
    """The leftmost strip's left border, extended straight at either end where another
    border of the road starts before it or ends after it (a road's lanes start and end on a
    line square to its reference; a skewed stop line leaves the outer lanes' ends beyond
    that line). Extensions are :data:`MIN_SPACING_M` at least, so no piece is tiny."""
    reference = thinned(np.asarray(strips[0].left, float))
    ends = np.vstack([np.asarray(b, float)[[0, -1]] for s in strips for b in (s.left, s.right)])
    parts = [reference]
    ends_tangent = tangents(reference)[[0, -1]]
    for at_end in (False, True):
        origin = reference[-1] if at_end else reference[0]
        outward = ends_tangent[1] if at_end else -ends_tangent[0]
        beyond = float(np.max((ends - origin) @ outward))
        if beyond > EXTEND_MIN_M:
            extra = origin + outward * max(beyond + EXTEND_MIN_M, MIN_SPACING_M)
            parts.insert(len(parts) if at_end else 0, extra[None])
    return np.vstack(parts)


def _shaped(road: _Road) -> _Road:
    """The road's reference line and the lateral position of every border along it."""
    road.pieces = reference_pieces(extended_reference(road.strips))
    road.line = DenseLine.of(road.pieces)
    road.stations = stations(road.line.length)
    borders = [np.asarray(s.left, float) for s in road.strips]
    borders.append(np.asarray(road.strips[-1].right, float))
    road.borders = lateral_profiles(road.line, borders, road.stations)
    return road


# --- links ----------------------------------------------------------------------------------

@dataclass
class _Links:
    """Road-level links and junctions of a set of roads."""

    roads: list[_Road]
    road_of: dict[str, _Road]
    by_id: dict[int, _Road] = field(default_factory=dict)
    succ: dict[int, set[int]] = field(default_factory=dict)
    pred: dict[int, set[int]] = field(default_factory=dict)
    junctions: dict[int, list[_Road]] = field(default_factory=dict)

    @classmethod
    def of(cls, roads: list[_Road]) -> _Links:
        """The road-level successors and predecessors of each road, and the junctions."""
        road_of = {s.id: r for r in roads for s in r.strips}
        links = cls(roads, road_of, {r.id: r for r in roads})
        for road in roads:
            links.succ[road.id] = {road_of[n].id for s in road.strips for n in s.successors
                                   if n in road_of} - {road.id}
            links.pred[road.id] = {road_of[n].id for s in road.strips for n in s.predecessors
                                   if n in road_of} - {road.id}
        links._find_junctions()
        return links

    def _is_connector(self, road: _Road) -> bool:
        """A road after a split (its predecessor continues into several roads) or before a
        merge (its successor continues from several): OpenDRIVE links such a predecessor or
        successor to a junction, whose connecting roads these are. Every road after a split
        is one, and every road before a merge, so a road's several successors (predecessors)
        always share one junction."""
        return any(len(self.succ[p]) > 1 for p in self.pred[road.id]) or \
            any(len(self.pred[s]) > 1 for s in self.succ[road.id])

    def _find_junctions(self) -> None:
        connectors = [r for r in self.roads if self._is_connector(r)]
        parent = {r.id: r.id for r in connectors}

        def root(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        seen: dict[tuple[str, int], int] = {}
        for road in connectors:
            keys = [("after", p) for p in self.pred[road.id] if p not in parent] + \
                   [("before", s) for s in self.succ[road.id] if s not in parent] + \
                   [("road", n) for n in self.pred[road.id] | self.succ[road.id] if n in parent]
            for key in keys:
                other = key[1] if key[0] == "road" else seen.setdefault(key, road.id)
                parent[root(road.id)] = root(other)
        first_id = max((r.id for r in self.roads), default=0) + 1
        numbering: dict[int, int] = {}
        for road in connectors:
            junction = numbering.setdefault(root(road.id), first_id + len(numbering))
            road.junction = junction
            self.junctions.setdefault(junction, []).append(road)

    def end_link(self, road: _Road, forward: bool) -> tuple[str, int, str] | None:
        """``(elementType, elementId, contactPoint)`` of the road's successor (``forward``)
        or predecessor, or ``None`` where it has none the map can express."""
        ends = [self.by_id[e] for e in sorted(self.succ[road.id] if forward
                                              else self.pred[road.id])]
        if not ends:
            return None
        if len(ends) == 1 and (road.junction >= 0 or ends[0].junction < 0):
            # from a connecting road to the next road, or between two plain roads
            back = self.pred[ends[0].id] if forward else self.succ[ends[0].id]
            if road.junction >= 0 or back == {road.id}:
                return "road", ends[0].id, "start" if forward else "end"
        junctions = {e.junction for e in ends}
        if len(junctions) == 1 and min(junctions) >= 0:
            return "junction", min(junctions), ""
        return None

    def lane_link(self, strip: LaneStrip, forward: bool, road_id: int) -> int | None:
        """The lane id of the strip's successor (predecessor) on road ``road_id``."""
        for other in strip.successors if forward else strip.predecessors:
            target = self.road_of.get(other)
            if target is not None and target.id == road_id:
                return target.lane_id(other)
        return None

    def unlinked(self) -> list[str]:
        """Strip links lost because neither a road link nor a junction expresses them."""
        lost = []
        for road in self.roads:
            for forward in (True, False):
                link = self.end_link(road, forward)
                for strip in road.strips:
                    for other in strip.successors if forward else strip.predecessors:
                        target = self.road_of.get(other)
                        if target is None or target is road:
                            continue
                        if link is None or (link[0] == "road" and link[1] != target.id) or (
                                link[0] == "junction" and target.junction != link[1]):
                            lost.append(f"{strip.id}->{other}" if forward else
                                        f"{other}->{strip.id}")
        return sorted(set(lost))


# --- signals --------------------------------------------------------------------------------

def _stop_point(light: RecordedLight, strip: LaneStrip) -> Floats:
    for lane, x0, y0, x1, y1 in light.stop_lines:
        if lane == strip.id:
            return np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    middle: Floats = (np.asarray(strip.left[-1], float) + np.asarray(strip.right[-1], float)) / 2
    return middle


def place_signals(lights: Iterable[RecordedLight], road_of: Mapping[str, _Road]
                  ) -> list[tuple[SignalPlacement, float]]:
    """One signal per light and governed strip, on that strip's lane at its stop line: the
    placement and the signal's ``t`` (the lane's centre there)."""
    placed, number = [], 0
    for light in lights:
        for strip_id in light.strips:
            road = road_of.get(strip_id)
            if road is None or road.line is None:
                continue
            index = [s.id for s in road.strips].index(strip_id)
            s_at, _, _ = road.line.project(_stop_point(light, road.strips[index])[None])
            margin = min(SIGNAL_MARGIN_M, road.length / 4)
            s = float(np.clip(s_at[0], margin, road.length - margin))
            number += 1
            placed.append((SignalPlacement(str(number), light.id, strip_id, road.id,
                                           -1 - index, s), road.lane_centre_t(index, s)))
    return placed


# --- writing --------------------------------------------------------------------------------

def _num(value: float) -> str:
    return format(float(value), ".12g")


def _sub(parent: etree._Element, tag: str, **attributes: object) -> etree._Element:
    return etree.SubElement(parent, tag, {k: _num(v) if isinstance(v, float) else str(v)
                                          for k, v in attributes.items()})


def _write_plan_view(element: etree._Element, pieces: list[Piece]) -> None:
    plan = _sub(element, "planView")
    for piece in pieces:
        geometry = _sub(plan, "geometry", s=piece.s, x=float(piece.a[0]), y=float(piece.a[1]),
                        hdg=piece.heading, length=piece.length)
        (au, bu, cu, du), (av, bv, cv, dv) = piece.local()
        _sub(geometry, "paramPoly3", aU=au, bU=bu, cU=cu, dU=du, aV=av, bV=bv, cV=cv, dV=dv,
             pRange="normalized")


def _write_link(element: etree._Element, links: _Links, road: _Road) -> None:
    link = _sub(element, "link")
    for tag, forward in (("predecessor", False), ("successor", True)):
        end = links.end_link(road, forward)
        if end is None:
            continue
        kind, element_id, contact = end
        if contact:
            _sub(link, tag, elementType=kind, elementId=element_id, contactPoint=contact)
        else:
            _sub(link, tag, elementType=kind, elementId=element_id)


def _write_lanes(element: etree._Element, links: _Links, road: _Road) -> None:
    assert road.line is not None
    lanes = _sub(element, "lanes")
    for s, a, b in linear_records(road.stations, road.borders[0]):
        _sub(lanes, "laneOffset", s=s, a=a, b=b, c=0.0, d=0.0)
    section = _sub(lanes, "laneSection", s=0.0)
    centre = _sub(_sub(section, "center"), "lane", id=0, type="none", level="false")
    _sub(centre, "roadMark", sOffset=0.0, type="none")
    right = _sub(section, "right")
    ends = {forward: links.end_link(road, forward) for forward in (False, True)}
    for k, (strip, width) in enumerate(zip(road.strips, road.widths(), strict=True)):
        lane = _sub(right, "lane", id=-1 - k, type=strip.lane_type, level="false")
        lane_links = _sub(lane, "link")
        for tag, forward in (("predecessor", False), ("successor", True)):
            end = ends[forward]
            if end is not None and end[0] == "road":
                target = links.lane_link(strip, forward, end[1])
                if target is not None:
                    _sub(lane_links, tag, id=target)
        for s, a, b in linear_records(road.stations, width):
            _sub(lane, "width", sOffset=s, a=max(a, 0.0), b=b, c=0.0, d=0.0)
        mark = "solid" if k == len(road.strips) - 1 else "broken"
        _sub(lane, "roadMark", sOffset=0.0, type=mark, weight="standard", color="standard",
             width=0.12)


def _write_signals(element: etree._Element, placed: list[tuple[SignalPlacement, float]]) -> None:
    if not placed:
        return
    signals = _sub(element, "signals")
    for placement, t in placed:
        signal = _sub(signals, "signal", s=placement.s, t=t, id=placement.signal_id,
                      name=f"light {placement.light_id}", dynamic="yes", orientation="+",
                      zOffset=3.0, country="OpenDRIVE", type=TRAFFIC_LIGHT_TYPE, subtype="-1",
                      height=1.0, width=0.4)
        _sub(signal, "validity", fromLane=placement.lane_id, toLane=placement.lane_id)


def _connections(links: _Links, forward: bool) -> list[tuple[int, _Road, _Road]]:
    """``(junction, road linking to it, connecting road)`` for every road whose successor
    (``forward``) or predecessor is a junction, and each of its roads on that side."""
    found = []
    for road in links.roads:
        end = links.end_link(road, forward)
        if end is not None and end[0] == "junction":
            neighbours = links.succ[road.id] if forward else links.pred[road.id]
            found += [(end[1], road, links.by_id[n]) for n in sorted(neighbours)]
    return found


def _write_junctions(root: etree._Element, links: _Links) -> None:
    """Each junction with a connection from every road that links to it ahead (its
    successor is the junction) to each of that road's successors, lane by lane. A junction
    nothing leads into (lanes that merge where the recording begins) gets the connections
    from the roads it leads to, against the traffic (``contactPoint="end"``): a junction
    without connections is no valid OpenDRIVE."""
    elements = {j: _sub(root, "junction", id=j, name=f"junction {j}")
                for j in sorted(links.junctions)}
    ahead = _connections(links, forward=True)
    reached = {junction for junction, _, _ in ahead}
    behind = [c for c in _connections(links, forward=False) if c[0] not in reached]
    for number, (junction, incoming, connecting) in enumerate(ahead + behind, start=1):
        forward = junction in reached
        connection = _sub(elements[junction], "connection", id=number,
                          incomingRoad=incoming.id, connectingRoad=connecting.id,
                          contactPoint="start" if forward else "end")
        for strip in connecting.strips:
            origin = links.lane_link(strip, not forward, incoming.id)
            if origin is not None:
                ends = {"from": origin, "to": connecting.lane_id(strip.id)}
                _sub(connection, "laneLink", **ends)


def _document(roads: list[_Road], links: _Links,
              placed: list[tuple[SignalPlacement, float]], name: str) -> bytes:
    root = etree.Element("OpenDRIVE")
    points = np.vstack([r.line.xy for r in roads if r.line is not None])
    (west, south), (east, north) = points.min(axis=0), points.max(axis=0)
    _sub(root, "header", revMajor=1, revMinor=4, name=name, version="1", north=float(north),
         south=float(south), east=float(east), west=float(west))
    for road in roads:
        element = _sub(root, "road", name=f"lanelets {' '.join(s.id for s in road.strips)}",
                       length=road.length, id=road.id, junction=road.junction)
        _write_link(element, links, road)
        _sub(element, "type", s=0.0, type="town")
        _write_plan_view(element, road.pieces)
        _sub(_sub(element, "elevationProfile"), "elevation", s=0.0, a=0.0, b=0.0, c=0.0, d=0.0)
        _write_lanes(element, links, road)
        _write_signals(element, [p for p in placed if p[0].road_id == road.id])
    _write_junctions(root, links)
    return bytes(etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True))


def convert(strips: Sequence[LaneStrip], lights: Sequence[RecordedLight] = (),
            name: str = "recorded road") -> ConvertedRoad:
    """The OpenDRIVE map of a recorded lane network; :class:`RecordedRoadError` naming the
    lanelet where one cannot be made."""
    if not strips:
        raise RecordedRoadError("the network has no lanelets")
    ids = [s.id for s in strips]
    if len(set(ids)) != len(ids):
        twice = sorted({i for i in ids if ids.count(i) > 1}, key=_id_key)
        raise RecordedRoadError(f"lanelet {twice[0]}: its id is used twice")
    for strip in strips:
        check_strip(strip)
    roads = [_shaped(_Road(number, group))
             for number, group in enumerate(group_strips(strips), start=1)]
    for road in roads:
        _check_shaped(road)
    links = _Links.of(roads)
    placed = place_signals(lights, links.road_of)
    xodr = _document(roads, links, placed, name)
    return ConvertedRoad(
        xodr=xodr,
        lanes={s.id: (r.id, r.lane_id(s.id)) for r in roads for s in r.strips},
        signals=tuple(p for p, _ in placed),
        junction_roads=frozenset(r.id for r in roads if r.junction >= 0),
        unlinked=tuple(links.unlinked()))


def _check_shaped(road: _Road) -> None:
    """No NaN and no zero-length piece may reach the file."""
    for piece in road.pieces:
        values = np.concatenate([piece.a, piece.b, piece.c, piece.d, [piece.length]])
        if not np.isfinite(values).all() or piece.length <= 1e-6:
            raise RecordedRoadError(f"lanelet {road.strips[0].id}: its left border gives a "
                                    f"degenerate reference piece at s={piece.s:.2f} m")
    for strip, border in zip(road.strips, road.borders, strict=False):
        if not np.isfinite(border).all() or not math.isfinite(road.length):
            raise RecordedRoadError(f"lanelet {strip.id}: its border could not be placed "
                                    "along the road")


def to_opendrive(strips: Sequence[LaneStrip], lights: Sequence[RecordedLight] = ()) -> bytes:
    """The OpenDRIVE text alone (:func:`convert` also says where each lanelet went)."""
    return convert(strips, lights).xodr

"""A map cut to some of its roads: the OpenDRIVE XML with only those roads, their junctions
(the connections between kept roads) and the controllers of their signals; links to anything
dropped removed, so the copy loads cleanly.

A :class:`MapCutter` holds one parsed map and assembles each copy from serialised pieces of
it (every road, junction and controller element made once), so cutting the same map to many
road sets costs little.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

from lxml import etree

#: a piece's key: its position in the map (and, for a road without some links, those links)
_Key = tuple[object, ...]


class MapCutter:
    """One map's XML, cut to road sets by :meth:`cut`."""

    def __init__(self, tree: etree._ElementTree) -> None:
        self.root = tree.getroot()
        #: the map's top-level elements
        self.children = list(self.root)
        roads = list(self.root.iterfind("road"))
        #: road id -> the junction it lies in (``-1`` or absent: none)
        self.junction_of = {road.get("id"): road.get("junction") for road in roads}
        #: signal id -> road id holding the ``<signal>``
        self.signal_roads = {signal.get("id"): road.get("id") for road in roads
                             for signal in road.iterfind("signals/signal")}
        self._pieces: dict[_Key, bytes] = {}
        self._shells: dict[_Key, tuple[bytes, bytes]] = {}
        #: road id -> its positions among the children; the positions of every other child:
        #: a cut walks the roads it keeps and those, not every road of the map
        self._road_positions: dict[str | None, list[int]] = {}
        self._other_positions: list[int] = []
        #: each road's link ends: (tag, kind of element, element id)
        self._links: dict[int, list[tuple[str, str, str | None]]] = {}
        for position, child in enumerate(self.children):
            if child.tag == "road":
                self._road_positions.setdefault(child.get("id"), []).append(position)
                self._links[position] = _link_ends(child)
            else:
                self._other_positions.append(position)

    def cut(self, roads: frozenset[str]) -> bytes:
        """The map with only ``roads``, their junctions (connections between kept roads) and
        the controllers of their signals; links to anything dropped removed."""
        junctions = {self.junction_of[r] for r in roads if r in self.junction_of}
        signals = {sid for sid, rid in self.signal_roads.items() if rid in roads}
        opening, closing = self._shell(("root",), self.root)
        parts = [b"<?xml version='1.0' encoding='utf-8'?>\n", opening]
        walked = [p for r in roads for p in self._road_positions.get(r, ())]
        for position in sorted(walked + self._other_positions):
            child = self.children[position]
            tag = child.tag if isinstance(child.tag, str) else ""
            if tag == "road":
                parts.append(self._road_bytes(position, child, roads, junctions))
            elif tag == "junction":
                if child.get("id") in junctions:
                    parts.append(self._filtered_bytes(position, child, "connection", lambda c: (
                        c.get("incomingRoad") in roads
                        and (c.get("connectingRoad") or c.get("linkedRoad")) in roads)))
            elif tag == "controller":
                kept = self._filtered_bytes(position, child, "control",
                                            lambda c: c.get("signalId") in signals)
                if b"<control " in kept:
                    parts.append(kept)
            else:
                parts.append(self._piece((position,), child))
        parts.append(closing)
        return b"".join(parts)

    def _piece(self, key: _Key, element: etree._Element) -> bytes:
        """``element`` (at ``key``: its position in the map) serialised with its tail."""
        if key not in self._pieces:
            self._pieces[key] = etree.tostring(element, encoding="utf-8", with_tail=True)
        return self._pieces[key]

    def _shell(self, key: _Key, element: etree._Element) -> tuple[bytes, bytes]:
        """``element``'s start tag (with its text) and end tag (with its tail), serialised."""
        if key not in self._shells:
            marker = "SCENWEAVE-CUT-MARKER"
            attributes = {str(name): str(value) for name, value in element.attrib.items()}
            shell = etree.Element(element.tag, attributes)
            shell.text = marker
            opening, closing = etree.tostring(shell, encoding="utf-8").decode().split(marker)
            self._shells[key] = ((opening + (element.text or "")).encode(),
                                 (closing + (element.tail or "")).encode())
        return self._shells[key]

    def _filtered_bytes(self, position: int, element: etree._Element, tag: str,
                        keep: Callable[[etree._Element], bool]) -> bytes:
        """``element`` with only the ``tag`` children ``keep`` accepts (other children kept)."""
        opening, closing = self._shell((position,), element)
        parts = [opening]
        for inner, child in enumerate(element):
            if child.tag != tag or keep(child):
                parts.append(self._piece((position, inner), child))
        parts.append(closing)
        return b"".join(parts)

    def _road_bytes(self, position: int, road: etree._Element, roads: frozenset[str],
                    junctions: set[str | None]) -> bytes:
        """A kept road, without the links to dropped roads or junctions."""
        dropped = tuple(tag for tag, kind, ref in self._links[position]
                        if ref not in (junctions if kind == "junction" else roads))
        if not dropped:
            return self._piece((position,), road)
        key = ("road", position, dropped)
        if key not in self._pieces:
            trimmed = copy.deepcopy(road)
            trimmed_link = trimmed.find("link")
            if trimmed_link is not None:  # it holds the dropped links
                for end in list(trimmed_link):
                    if end.tag in dropped:
                        trimmed_link.remove(end)
            self._pieces[key] = etree.tostring(trimmed, encoding="utf-8", with_tail=True)
        return self._pieces[key]


def _link_ends(road: etree._Element) -> list[tuple[str, str, str | None]]:
    """A road's ``link`` ends (predecessor, successor): tag, kind of element, element id."""
    link = road.find("link")
    return [(end.tag, end.get("elementType", "road"), end.get("elementId"))
            for end in (link if link is not None else ()) if isinstance(end.tag, str)]

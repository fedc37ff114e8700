"""A map cut to some roads: only those roads, their junctions and controllers, no link to a
dropped road; cut to every road it is the map."""

from __future__ import annotations

from lxml import etree

from scenweave.roads import DEFAULT_MAP_PATH, MapCutter, road_graph


def test_a_cut_to_every_road_is_the_map():
    cutter = MapCutter(etree.parse(str(DEFAULT_MAP_PATH)))
    whole = etree.fromstring(cutter.cut(frozenset(road_graph(DEFAULT_MAP_PATH).roads)))
    original = etree.parse(str(DEFAULT_MAP_PATH)).getroot()
    assert etree.tostring(whole, method="c14n") == etree.tostring(original, method="c14n")


def test_a_cut_holds_the_roads_kept_and_links_only_to_them():
    graph = road_graph(DEFAULT_MAP_PATH)
    start = [("45", 500.0, (1,))]  # 85 m before a junction
    kept, ends = graph.reach(start, 300.0)
    kept |= {road for end in ends for road, _ in graph.touches[end]}
    root = etree.fromstring(MapCutter(etree.parse(str(DEFAULT_MAP_PATH))).cut(frozenset(kept)))
    roads = {road.get("id") for road in root.iterfind("road")}
    junctions = {junction.get("id") for junction in root.iterfind("junction")}
    assert roads == kept and len(roads) < len(graph.roads)
    assert junctions, "the reach crosses a junction"
    for road in root.iterfind("road"):
        for link in road.iterfind("link/*"):
            named = junctions if link.get("elementType") == "junction" else roads
            assert link.get("elementId") in named
    for connection in root.iterfind("junction/connection"):
        assert {connection.get("incomingRoad"), connection.get("connectingRoad")} <= roads
    signals = {s.get("id") for s in root.iter("signal")}
    assert {c.get("signalId") for c in root.iter("control")} <= signals

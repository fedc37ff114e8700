"""The hand-written lane network of ``tests/roads/recorded_network.py`` as a CommonRoad 2020a
file (lanelets, stop line, light 500 with its cycle, one car), for the reader's and the cached
converter's tests."""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from tests.mining.make_fixtures import _light, _points, _state, _sub
from tests.roads.recorded_network import HALF, lanelets


def _lanelet(root: etree._Element, lanelet_id: int, spec: dict[str, object]) -> None:
    element = _sub(root, "lanelet", id=str(lanelet_id))
    left, right = spec["bounds"]  # type: ignore[misc]
    _points(element, "leftBound", left)
    _points(element, "rightBound", right)
    for key, tag in (("pred", "predecessor"), ("succ", "successor")):
        for other in spec.get(key, []):  # type: ignore[attr-defined]
            _sub(element, tag, ref=str(other))
    for side in ("left", "right"):
        if side in spec:
            _sub(element, f"adjacent{side.title()}", ref=str(spec[side]),
                 drivingDir=str(spec.get(f"{side}_dir", "same")))
    if lanelet_id == 9:
        stop = _sub(element, "stopLine")
        for y in (HALF, -HALF):
            point = _sub(stop, "point")
            _sub(point, "x", 200.0)
            _sub(point, "y", y)
        _sub(stop, "lineMarking", "solid")
    _sub(element, "laneletType", "urban")
    if "light" in spec:
        _sub(element, "trafficLightRef", ref=str(spec["light"]))


def write_road_fixture(path: Path, broken: int | None = None) -> Path:
    """Write the network (and one car driving it for 3 s) to ``path``; ``broken``: that
    lanelet's borders collapse to one point each (a network the converter must refuse)."""
    root = etree.Element("commonRoad", commonRoadVersion="2020a",
                         benchmarkID="ZAM_Road-1_1_T-1", timeStepSize="0.1",
                         author="ScenWeave tests", affiliation="ScenWeave", source="synthetic",
                         date="2026-01-01")
    location = _sub(root, "location")
    for tag, value in (("geoNameId", -999), ("gpsLatitude", 48.26), ("gpsLongitude", 11.67)):
        _sub(location, tag, value)
    _sub(_sub(root, "scenarioTags"), "urban")
    for lanelet_id, spec in lanelets().items():
        if lanelet_id == broken:
            left, right = spec["bounds"]  # type: ignore[misc]
            spec = {**spec, "bounds": ([left[0]] * 2, [right[0]] * 2)}
        _lanelet(root, lanelet_id, spec)
    _light(root, 500, [("green", 20), ("yellow", 5), ("red", 20)], 0)
    obstacle = _sub(root, "dynamicObstacle", id="900")
    _sub(obstacle, "type", "car")
    rectangle = _sub(_sub(obstacle, "shape"), "rectangle")
    _sub(rectangle, "length", 4.5)
    _sub(rectangle, "width", 1.8)
    trajectory = None
    for step in range(30):
        _state(obstacle if step == 0 else trajectory, "initialState" if step == 0 else "state",
               step, 10.0 + step, 0.0, 0.0, 10.0)
        if step == 0:
            trajectory = _sub(obstacle, "trajectory")
    etree.ElementTree(root).write(str(path), pretty_print=True, xml_declaration=True,
                                  encoding="UTF-8")
    return path

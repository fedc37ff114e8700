"""The OpenDRIVE reader against facts of the map file itself, read independently."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from scenweave.roads import DEFAULT_MAP_PATH, OpenDriveError, load_opendrive
from scenweave.roads.lanes import driving_direction, lane_center_offset, lane_distance
from tests.roads.synthetic_maps import opendrive, road_xml, write

RAW = ET.parse(DEFAULT_MAP_PATH).getroot()


def _raw_road(road_id: str) -> ET.Element:
    return next(r for r in RAW.findall("road") if r.get("id") == road_id)


def test_every_geometry_starts_where_the_file_says(town04):
    # each geometry's end must land on the x/y the file states for the next one (and road
    # starts on its first): an independent check of line and arc evaluation
    worst = 0.0
    for element in RAW.findall("road"):
        road = town04.road(element.get("id"))
        for geometry in element.findall("planView/geometry"):
            pose = road.plan_view.pose(float(geometry.get("s")))
            worst = max(worst, math.hypot(pose.x[0] - float(geometry.get("x")),
                                          pose.y[0] - float(geometry.get("y"))))
            # evaluate the previous geometry right up to its end
            s_end = float(geometry.get("s")) - 1e-9
            if s_end > 0:
                before = road.plan_view.pose(s_end)
                worst = max(worst, math.hypot(before.x[0] - float(geometry.get("x")),
                                              before.y[0] - float(geometry.get("y"))))
    assert worst < 0.01


def test_connected_lanes_join_within_5cm(town04):
    gaps = []
    for key in town04.drivable_lanes():
        exit_s = town04.exit_s(key)
        here = town04.key_to_world(key, exit_s)
        for target in town04.successors(key):
            there = town04.key_to_world(target, town04.entry_s(target))
            gaps.append(math.hypot(here.x - there.x, here.y - there.y))
    assert len(gaps) > 400
    assert max(gaps) < 0.05


@pytest.mark.parametrize(("road_id", "lane_id", "s"), [
    ("45", -3, 100.0), ("45", 6, 400.0), ("16", 1, 20.0), ("23", -3, 200.0), ("1", -1, 50.0),
])
def test_lane_centre_offset_is_the_summed_widths(town04, road_id, lane_id, s):
    element = _raw_road(road_id)

    def poly(records, s_local):
        chosen = [r for r in records if float(r.get("s", r.get("sOffset"))) <= s_local][-1]
        ds = s_local - float(chosen.get("s", chosen.get("sOffset")))
        return sum(float(chosen.get(k)) * ds**i for i, k in enumerate("abcd"))

    offset = poly(element.findall("lanes/laneOffset"), s)
    section = [e for e in element.findall("lanes/laneSection") if float(e.get("s")) <= s][-1]
    s_local = s - float(section.get("s"))
    widths = {int(lane.get("id")): poly(lane.findall("width"), s_local)
              for lane in section.iter("lane") if lane.get("id") != "0"}
    sign = 1 if lane_id > 0 else -1
    inner = sum(widths[sign * i] for i in range(1, abs(lane_id)))
    expected = offset + sign * (inner + widths[lane_id] / 2)
    road = town04.road(road_id)
    t, _ = lane_center_offset(road, road.sections[road.section_index(s)], lane_id, np.array([s]))
    assert t[0] == pytest.approx(expected, abs=1e-9)


def test_speed_records_are_converted_from_mph(town04):
    assert _raw_road("45").find("type/speed").attrib == {"max": "65", "unit": "mph"}
    assert town04.road("45").speed_limit_kmh(10.0) == pytest.approx(65 * 1.609344)


def test_outer_lane_of_a_curve_is_longer_than_s(town04):
    # town04.md: 30 m of s on curved road 45 is 32.0 m along lane -3
    road = town04.road("45")
    along = lane_distance(road, road.sections[0], -3, 100.0, 130.0)
    assert along == pytest.approx(32.0, abs=0.1)
    # and the integral agrees with a fine polyline through the lane centre
    points = [town04.lane_to_world("45", -3, s) for s in np.linspace(100, 130, 3001)]
    polyline = sum(math.hypot(b.x - a.x, b.y - a.y) for a, b in zip(points, points[1:],
                                                                    strict=False))
    assert along == pytest.approx(polyline, abs=1e-4)


def test_heading_follows_traffic(town04):
    right = town04.lane_to_world("48", -1, 30.0)
    left = town04.lane_to_world("48", 3, 30.0)
    assert driving_direction(-1) == 1 and driving_direction(3) == -1
    assert abs(abs(right.h - left.h) - math.pi) < 1e-9


def test_signals_and_references_are_read(town04):
    references = sum(len(r.signal_references) for r in town04.map.roads.values())
    lights = [s for r in town04.map.roads.values() for s in r.signals if s.dynamic]
    assert references == len(list(RAW.iter("signalReference")))
    assert len(lights) == len([s for s in RAW.iter("signal") if s.get("dynamic") == "yes"])
    assert town04.map.signal("1607").road_id == "16"


def test_border_lanes_are_refused_with_the_road_named(tmp_path):
    road = road_xml("7", 10.0, '<geometry s="0" x="0" y="0" hdg="0" length="10"><line/></geometry>')
    road = road.replace('<width sOffset="0" a="3.5"', '<border sOffset="0" a="3.5"')
    with pytest.raises(OpenDriveError, match="road 7.*border"):
        load_opendrive(write(tmp_path, opendrive(road)))


def test_unreadable_files_name_the_file(tmp_path):
    with pytest.raises(OpenDriveError, match="missing.xodr"):
        load_opendrive(tmp_path / "missing.xodr")
    with pytest.raises(OpenDriveError, match="bad.xodr"):
        load_opendrive(write(tmp_path, "<OpenDRIVE><road", "bad.xodr"))
    geometry = '<geometry s="0" x="0" y="0" hdg="0" length="10"><clothoid/></geometry>'
    with pytest.raises(OpenDriveError, match="clothoid"):
        load_opendrive(write(tmp_path, opendrive(road_xml("3", 10.0, geometry))))


def test_every_plan_view_kind_is_read_from_xml(tmp_path):
    geometry = """
        <geometry s="0" x="0" y="0" hdg="0" length="50"><spiral curvStart="0" curvEnd="0.02"/>
        </geometry>
        <geometry s="50" x="60" y="10" hdg="0.5" length="20"><poly3 a="0" b="0" c="0.001" d="0"/>
        </geometry>
        <geometry s="70" x="80" y="20" hdg="0.6" length="30">
            <paramPoly3 aU="0" bU="30" cU="0" dU="0" aV="0" bV="0" cV="2" dV="0"
                        pRange="normalized"/>
        </geometry>
        <geometry s="100" x="100" y="40" hdg="0.7" length="10">
            <paramPoly3 aU="0" bU="1" cU="0" dU="0" aV="0" bV="0" cV="0" dV="0" pRange="arcLength"/>
        </geometry>"""
    odr = load_opendrive(write(tmp_path, opendrive(road_xml("5", 110.0, geometry))))
    spiral, poly3, normalized, arc_length = odr.roads["5"].plan_view.geometries
    assert (spiral.curv_start, spiral.curv_end) == (0.0, 0.02)
    assert poly3.coeff_v == (0.0, 0.0, 0.001, 0.0) and poly3.p_end is None
    assert normalized.coeff_v == (0.0, 0.0, 2.0, 0.0) and normalized.p_end == 1.0
    assert arc_length.p_end == 10.0
    pose = odr.roads["5"].plan_view.pose(np.array([50.0, 105.0]))
    # spiral end: heading = k1 * L / 2; the arcLength line runs 5 m along hdg 0.7
    assert pose.hdg[0] == pytest.approx(0.02 * 50 / 2)
    assert (pose.x[1], pose.y[1]) == pytest.approx((100 + 5 * math.cos(0.7),
                                                    40 + 5 * math.sin(0.7)))
    assert odr.roads["5"].speed_limit_kmh(0.0) == 50.0

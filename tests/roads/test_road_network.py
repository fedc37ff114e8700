"""Walking along lanes: distances along the lane centre, across road boundaries, dead ends."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenweave.roads import LaneEndsError, OpenDriveError, RoadNetwork, load_opendrive
from scenweave.roads.road_network import LanePoint
from tests.roads.synthetic_maps import two_road_chain, write


@pytest.fixture
def chain(tmp_path) -> RoadNetwork:
    return RoadNetwork(load_opendrive(write(tmp_path, two_road_chain())))


def _polyline_length(network: RoadNetwork, road_id: str, lane_id: int, s0: float, s1: float):
    points = [network.lane_to_world(road_id, lane_id, s) for s in np.linspace(s0, s1, 4001)]
    return sum(math.hypot(b.x - a.x, b.y - a.y) for a, b in zip(points, points[1:],
                                                                strict=False))


def test_advance_crosses_into_the_successor_road(chain):
    point = chain.advance("1", -1, 90.0, 30.0)
    assert (point.road_id, point.lane_id) == ("2", -1)
    # lane -1 is 1.75 m right of the reference line: on a left arc of radius 100 it is longer
    # than s by the factor (100 + 1.75) / 100
    assert point.s == pytest.approx(20.0 / (101.75 / 100), abs=1e-6)
    assert _polyline_length(chain, "2", -1, 0.0, point.s) == pytest.approx(20.0, abs=1e-4)


def test_advance_backwards_returns_to_the_start(chain):
    ahead = chain.advance("1", -2, 70.0, 55.0)
    back = chain.advance(ahead.road_id, ahead.lane_id, ahead.s, -55.0)
    assert back.road_id == "1" and back.lane_id == -2
    assert back.s == pytest.approx(70.0, abs=1e-6)


def test_distance_between_two_lane_positions_is_measured_along_the_lane(chain):
    start, end = LanePoint("1", -1, 90.0), LanePoint("2", -1, 15.0)
    polyline = (_polyline_length(chain, "1", -1, 90.0, 100.0)
                + _polyline_length(chain, "2", -1, 0.0, 15.0))
    assert chain.distance_between(start, end, 100.0) == pytest.approx(polyline, abs=1e-4)
    assert chain.distance_between(end, start, 100.0) == pytest.approx(-polyline, abs=1e-4)
    assert chain.distance_between(start, LanePoint("2", -2, 15.0), 100.0) is None
    assert chain.distance_between(start, end, 5.0) is None  # beyond the cap
    within = _polyline_length(chain, "1", -2, 20.0, 70.0)  # one lane section of one road
    assert chain.distance_between(LanePoint("1", -2, 20.0), LanePoint("1", -2, 70.0),
                                  100.0) == pytest.approx(within, abs=1e-4)
    assert chain.distance_between(LanePoint("1", -2, 70.0), LanePoint("1", -2, 20.0),
                                  100.0) == pytest.approx(-within, abs=1e-4)


def test_widening_lane_length_includes_the_lateral_drift(chain):
    # lane -2 widens by 1 cm per metre: its centre drifts sideways as it goes
    ahead = chain.advance("1", -2, 0.0, 80.0)
    assert _polyline_length(chain, "1", -2, 0.0, ahead.s) == pytest.approx(80.0, abs=1e-4)
    assert ahead.s < 80.0


def test_running_off_the_network_names_the_shortfall(chain):
    with pytest.raises(LaneEndsError, match=r"lane -1 of road 1 .* ahead, 500.0 m needed"):
        chain.advance("1", -1, 10.0, 500.0)
    assert chain.drivable_length("1", -1, 10.0, forward=True, cap=1000) == pytest.approx(
        90.0 + 50.0 * 101.75 / 100, abs=1e-6)
    assert chain.drivable_length("1", -1, 10.0, forward=False, cap=1000) == pytest.approx(10.0)


def test_bad_positions_are_errors(chain):
    with pytest.raises(OpenDriveError, match="no road with id 9"):
        chain.lane_to_world("9", -1, 0.0)
    with pytest.raises(OpenDriveError, match="outside the road"):
        chain.lane_to_world("1", -1, 150.0)
    with pytest.raises(OpenDriveError, match="no lane -3"):
        chain.lane_to_world("1", -3, 10.0)


def test_elevation_and_heading_of_a_lane_position(chain):
    pose = chain.lane_to_world("1", -1, 40.0)
    assert (pose.x, pose.y, pose.z) == pytest.approx((40.0, -1.75, 1.0 + 0.01 * 40.0))
    assert pose.h == pytest.approx(0.0)


def test_town04_gap_across_a_junction_is_measured_along_the_lane(town04):
    # road 45 ends in junction 134: 30 m from 10 m before its end lands on the junction road
    road = town04.road("45")
    point = town04.advance("45", -3, road.length - 10.0, 30.0)
    assert point.road_id != "45" and point.lane_id == -3
    back = town04.advance(point.road_id, point.lane_id, point.s, -30.0)
    assert (back.road_id, back.lane_id) == ("45", -3)
    assert back.s == pytest.approx(road.length - 10.0, abs=1e-6)


def test_neighbours_are_same_direction_lanes(town04):
    key = town04.key_at("45", -2, 100.0)
    assert town04.neighbour(key, "left").lane_id == -1
    assert town04.neighbour(key, "right").lane_id == -3
    assert town04.neighbour(town04.key_at("45", -1, 100.0), "left") is None
    # left lanes drive the other way: their "left" is the lower id
    assert town04.neighbour(town04.key_at("45", 4, 100.0), "left").lane_id == 3


def test_heading_of_a_widening_lane_follows_its_centre_line(chain):
    # lane -2's centre drifts right by half of 1 cm per metre: heading atan(-0.005)
    pose = chain.lane_to_world("1", -2, 40.0)
    assert pose.h == pytest.approx(math.atan(-0.005), abs=1e-12)
    ahead = chain.lane_to_world("1", -2, 41.0)
    assert math.atan2(ahead.y - pose.y, ahead.x - pose.x) == pytest.approx(pose.h, abs=1e-9)


def test_closed_form_lane_distance_equals_the_quadrature_on_town04(town04):
    # where a lane keeps its offset on a line or arc, lane_distance takes a closed form; it
    # must agree with the Gauss-Legendre integral it replaces (and be used somewhere)
    from scenweave.roads.lanes import (
        _constant_centre_offset,
        integrated_lane_distance,
        lane_distance,
    )

    closed_form = 0
    for key in list(town04.drivable_lanes())[::7]:
        road = town04.road(key.road_id)
        section = road.sections[key.section]
        for low, high in ((section.s_start, section.s_end),
                          (section.s_start + 0.3 * (section.s_end - section.s_start),
                           section.s_start + 0.6 * (section.s_end - section.s_start))):
            if _constant_centre_offset(road, section, key.lane_id, low, high) is not None \
                    and road.plan_view.constant_curvature_on(low, high) is not None:
                closed_form += 1
            assert lane_distance(road, section, key.lane_id, low, high) == pytest.approx(
                integrated_lane_distance(road, section, key.lane_id, low, high), abs=1e-9)
    assert closed_form > 20

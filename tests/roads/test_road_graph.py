"""The road graph: road ends joined by links and junction connections, reach along the
straightest connections, near-shortest routes, roads near a point."""

from __future__ import annotations

import math

import pytest

from scenweave.roads import DEFAULT_MAP_PATH, load_opendrive, road_graph
from scenweave.roads.road_graph import TIE_TOLERANCE, build_road_graph
from tests.roads.synthetic_maps import two_road_chain, write


@pytest.fixture
def chain(tmp_path):
    return build_road_graph(load_opendrive(write(tmp_path, two_road_chain())))


@pytest.fixture(scope="module")
def town04():
    return road_graph(DEFAULT_MAP_PATH)


def test_road_ends_touch_through_links_and_traffic_drives_along_the_right_lanes(chain):
    assert chain.touches[("1", 1)] == {("2", 0)} and chain.touches[("2", 0)] == {("1", 1)}
    assert chain.touches[("1", 0)] == set()
    assert chain.road_links == {("1", 1): [("2", 0)], ("2", 0): [("1", 1)]}
    assert chain.drives == {"1": (True, False), "2": (True, False)}
    assert chain.toward[("1", 1)] == {-1, -2} and chain.toward[("1", 0)] == set()
    assert chain.enters("2", 0) and not chain.enters("2", 1)
    assert chain.numeric_ids and chain.total_length == 150.0


def test_reach_and_routes_are_measured_in_metres_driven(chain):
    start = [("1", 10.0, (1,))]
    assert chain.reach(start, 50.0) == ({"1"}, set())
    assert chain.reach(start, 100.0) == ({"1", "2"}, {("1", 1)})
    assert chain.forward(start) == {("2", 0): 90.0}
    assert chain.routes(start, {"2"}, slack=1.5, margin_m=0.0) == ({"1", "2"}, 90.0)
    assert chain.routes([("1", 10.0, (-1,))], {"2"}, 1.5, 0.0) == (set(), math.inf)


def test_a_junction_is_left_by_the_straightest_connection_of_each_lane(town04):
    junction_ends = [end for end, options in town04.lane_options.items() if options]
    assert junction_ends
    for road, end in junction_ends:
        chosen = town04.choices(road, end)
        options = town04.lane_options[(road, end)]
        assert set(chosen) <= {option for found in options.values() for option in found}
        assert set(chosen) <= set(town04.choices(road, end, routed=True))
        heading_in = town04.end_headings[road][end] + (0.0 if end == 1 else math.pi)
        lanes = town04.toward[(road, end)] & options.keys() or set(options)
        for lane in lanes:
            turns = {option: abs(math.remainder(town04._exit_heading(*option) - heading_in,
                                                2 * math.pi)) for option in options[lane]}
            best = min(turns.values())
            assert {o for o, turn in turns.items() if turn <= best + TIE_TOLERANCE} \
                <= set(chosen)


def test_the_roads_near_a_point_come_nearest_first(town04):
    road = town04.roads["45"]
    pose = road.plan_view.pose(road.length / 2)
    x, y = float(pose.x[0]), float(pose.y[0])
    near = town04.roads_near(x, y, 30.0)
    assert next(iter(near)) == "45"
    s, heading = near["45"]
    assert s == pytest.approx(road.length / 2, abs=1.0)
    assert heading == pytest.approx(float(pose.hdg[0]), abs=0.05)
    assert town04.side_of("45", s, x, y) == pytest.approx(0.0, abs=0.1)
    far = town04.roads_near(x + 1e5, y, 1.0)
    assert len(far) == 1  # always the nearest road, however far

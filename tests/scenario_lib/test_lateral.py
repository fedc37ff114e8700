"""scenario_lib.lateral: a recorded lane change's two parts, from its params (issue 31)."""

from __future__ import annotations

import math

import pytest

from scenweave.scenario_lib.lateral import (
    SETTLE_AFTER_CROSSING_S,
    along_lane_m,
    recorded_lane_change,
    road_offset,
)

BASE = {"maneuver_start_s": 2.0, "duration_s": 4.0, "lane_change_direction": "left",
        "npc_speed_ms": 20.0, "npc_end_speed_ms": 20.0, "lane_change_width_m": 3.5}


def test_from_the_centre_the_first_part_takes_twice_the_time_to_the_line():
    timing = recorded_lane_change(BASE | {"lane_change_cross_s": 1.0}, "npc")
    assert timing is not None
    assert (timing.start_s, timing.first_s, timing.cross_s) == (2.0, 2.0, 3.0)
    # 2 s at 20 m/s along the slanted path, 3.5 m of it across: the lane's leg
    assert timing.first_m == pytest.approx(math.sqrt(40.0 ** 2 - 3.5 ** 2), abs=1e-3)
    assert timing.settle_start_s == pytest.approx(3.0 + SETTLE_AFTER_CROSSING_S)
    assert timing.settle_s == pytest.approx(4.0 - 1.0 - SETTLE_AFTER_CROSSING_S)
    # 0.2 s past the crossing, 1.4 m are left across (3.5 x (1 - 24 / 40))
    assert timing.settle_m == pytest.approx(
        math.sqrt((20.0 * timing.settle_s) ** 2 - 1.4 ** 2), abs=1e-3)


def test_at_town_speeds_the_change_is_sized_along_the_lane_not_the_path():
    """Issue 36: a player moves a changing car at its speed along its slanted path; at 2.1 m/s
    a 3.5 m change crossing 1.91 s in drives 8.1 m of path but 7.3 m of lane (sized by the
    path, it crossed 0.24 s late in esmini, Peachtree 2 LCF row 2)."""
    slow = BASE | {"npc_speed_ms": 2.1, "npc_end_speed_ms": 2.1, "lane_change_cross_s": 1.91}
    timing = recorded_lane_change(slow, "npc")
    assert timing is not None
    path = 2 * 2.1 * 1.91
    assert timing.first_m == pytest.approx(along_lane_m(path, 3.5), abs=1e-3)
    assert path - timing.first_m > 0.7
    assert along_lane_m(3.0, 3.5) == 0.0  # steeper than the lane allows: the floor decides


def test_a_car_recorded_mid_change_moves_the_rest_of_the_way_at_its_own_rate():
    # 1.0 m toward the new lane, 0.75 m before the line, crossing 0.6 s later: 2.5 m to go
    params = BASE | {"lane_change_cross_s": 0.6, "npc_lane_offset_m": 1.0}
    timing = recorded_lane_change(params, "npc")
    assert timing is not None and timing.offset_toward_m == 1.0
    assert timing.first_s == pytest.approx(0.6 * 2.5 / 0.75, abs=1e-3)
    # to the right, an offset to the left is away from the new lane
    right = recorded_lane_change(params | {"lane_change_direction": "right"}, "npc")
    assert right is not None and right.offset_toward_m == -1.0
    assert right.first_s == pytest.approx(0.6 * 4.5 / 2.75, abs=1e-3)  # ms, as written


def test_a_moove_row_or_a_car_past_the_line_is_not_timed():
    assert recorded_lane_change(BASE, "npc") is None  # no crossing: one linear change
    past = BASE | {"lane_change_cross_s": 0.5, "npc_lane_offset_m": 1.8}
    assert recorded_lane_change(past, "npc") is None


def test_the_offset_is_turned_into_opendrives_t_by_the_lanes_direction():
    assert road_offset({"npc_lane_offset_m": 0.8, "npc_lane_id": -2}, "npc") == 0.8
    assert road_offset({"npc_lane_offset_m": 0.8, "npc_lane_id": 3}, "npc") == -0.8
    assert road_offset({"npc_lane_id": -2}, "npc") == 0  # the lane's centre, as before

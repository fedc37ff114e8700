"""SpawnMatcher: Table 5.3 ranking, hard filters, manoeuvre fit, conversion, round robin."""

from __future__ import annotations

import math

import pytest

from scenweave.scenario_lib.vehicles import ego_front_m
from scenweave.spawn_db import NoSpawnFits, ParamsError, SpawnMatcher
from tests.spawn_db.contract_params import highway, urban


@pytest.fixture(scope="module")
def matcher() -> SpawnMatcher:
    return SpawnMatcher()


def _by_id(matcher: SpawnMatcher) -> dict[int, dict]:
    return {entry["spawn_id"]: entry for entry in matcher.entries}


def test_find_ranks_highway_candidates_best_first(matcher):
    candidates = matcher.find(highway("BRAKE"), top_n=8)
    assert len(candidates) == 8
    scores = [c.score for c in candidates]
    assert scores == sorted(scores, reverse=True)
    assert all(c.entry["context"] == "highway" for c in candidates)
    # equal scores are spread over roads rather than stacked on one
    assert len({c.entry["geometry"]["road_id"] for c in candidates}) >= 4


def test_highway_score_follows_table_5_3(matcher):
    candidate = matcher.find(highway("BRAKE", ego_ms=104.6 / 3.6), top_n=1)[0]
    entry = candidate.entry
    expected = (30 + 20 + 15 * entry["features"]["is_straight"]
                + 10 * entry["surroundings"]["is_highway_layout"]
                + 15 * (entry["drivable"]["ahead_m"] > 100)
                + 10 * entry["annotations"]["priority"])
    assert candidate.score == pytest.approx(expected, abs=0.01)


def test_conversion_to_openscenario_frame(matcher):
    candidate = matcher.find(highway("BRAKE"), top_n=1)[0]
    transform = candidate.entry["transform"]
    assert candidate.y == -transform["y"]
    assert candidate.h == pytest.approx(-math.radians(transform["yaw"]))
    x, y, _, h = (matcher.network.lane_to_world(*candidate.lane_point).__dict__[k]
                  for k in ("x", "y", "z", "h"))
    assert (candidate.x, candidate.y) == pytest.approx((x, y), abs=1e-3)
    assert math.cos(candidate.h - h) == pytest.approx(1.0)


def test_round_robin_cycles_through_the_top_n(matcher):
    params = highway("BRAKE")
    top = [c.spawn_id for c in matcher.find(params, top_n=5)]
    assigned = [matcher.assign(params, index, top_n=5)["spawn_id"] for index in range(7)]
    assert assigned == top + top[:2]
    assert len(set(top)) == 5


def test_assign_returns_a_new_dict_with_ego_and_npc_along_the_lane(matcher):
    params = highway("BRAKE", npc_distance_m=42.0)
    result = matcher.assign(params, 0)
    assert params["spawn_id"] is None and "ego_x" not in params
    network = matcher.network
    # 42 m at the manoeuvre start (2 s); the lead is 2 m/s slower, so it starts 46 m ahead
    # along the ego's lane: walking back 46 m finds the ego
    back = network.advance(str(result["npc_road_id"]), result["npc_lane_id"], result["npc_s"],
                           -46.0)
    assert (back.road_id, back.lane_id) == (str(result["ego_road_id"]), result["ego_lane_id"])
    assert back.s == pytest.approx(result["ego_s"], abs=1e-3)
    pose = network.lane_to_world(result["npc_road_id"], result["npc_lane_id"], result["npc_s"])
    assert (result["npc_x"], result["npc_y"], result["npc_h"]) == pytest.approx(
        (pose.x, pose.y, pose.h), abs=1e-3)


def _off_lane_m(network, road_id, lane_id: int, s: float, x: float, y: float) -> float:
    """Distance from (x, y) to the nearest point of the lane centre within 40 m of ``s``
    (searched every 0.5 m, then every 5 mm around the nearest)."""
    length = network.road(road_id).length

    def nearest(centre: float, step: float, count: int) -> tuple[float, float]:
        values = [min(max(centre + i * step, 0.0), length) for i in range(-count, count + 1)]
        poses = [network.lane_to_world(road_id, lane_id, v) for v in values]
        return min((math.hypot(p.x - x, p.y - y), v) for p, v in zip(poses, values, strict=True))

    _, coarse = nearest(s, 0.5, 80)
    return nearest(coarse, 0.005, 100)[0]


def test_highway_npc_starts_on_its_lane_centre_on_a_curved_road(matcher):
    """Road 45 curves: the lead, 10 m/s slower, starts 20 m further on than its gap at the
    manoeuvre start. Moved along its lane it stays on the lane centre; a straight shift of
    the pose at the recorded gap along its heading would leave the lane by metres."""
    params = highway("BRAKE", npc_distance_m=40.0, npc_speed_ms=20.0)
    candidates = matcher.find(params, top_n=len(matcher.entries))
    # road 45 is an arc of radius 180 m up to s = 290 (the lane must bend from the ego to 60 m on)
    on_45 = [i for i, c in enumerate(candidates)
             if c.lane_point.road_id == "45" and c.lane_point.s <= 220.0]
    assert on_45
    network = matcher.network
    for index in on_45[:3]:
        result = matcher.assign(params, index, top_n=len(matcher.entries))
        road, lane, s = str(result["npc_road_id"]), result["npc_lane_id"], result["npc_s"]
        assert road == "45"
        assert _off_lane_m(network, road, lane, s, result["npc_x"], result["npc_y"]) < 0.1
        back = network.advance(road, lane, s, -60.0)
        assert (back.road_id, back.s) == ("45", pytest.approx(result["ego_s"], abs=1e-3))
        at_gap = network.advance(str(result["ego_road_id"]), result["ego_lane_id"],
                                 result["ego_s"], 40.0)
        pose = network.lane_to_world(*at_gap)
        straight = (pose.x + 20.0 * math.cos(pose.h), pose.y + 20.0 * math.sin(pose.h))
        assert _off_lane_m(network, road, lane, s, *straight) > 0.5


@pytest.mark.parametrize(("code", "side"), [("CINF", "right"), ("CINB", "left")])
def test_cut_in_npc_starts_in_the_adjacent_lane(matcher, code, side):
    distance = 20.0 if code == "CINF" else -15.0
    params = highway(code, npc_distance_m=distance, sides=(side,))
    distance += 2.0 * 2.0  # 2 m/s slower for the 2 s before the cut-in: it starts further on
    for index in range(5):
        result = matcher.assign(params, index)
        ego = matcher.network.key_at(result["ego_road_id"], result["ego_lane_id"],
                                     result["ego_s"])
        neighbour = matcher.network.neighbour(ego, side)
        back = matcher.network.advance(result["npc_road_id"], result["npc_lane_id"],
                                       result["npc_s"], -distance)
        assert (back.road_id, back.lane_id) == (ego.road_id, neighbour.lane_id)
        assert back.s == pytest.approx(result["ego_s"], abs=1e-3)


def test_lane_change_needs_a_lane_on_that_side(matcher):
    params = highway("LCF", npc_distance_m=None, sides=("left",))
    entries = _by_id(matcher)
    for candidate in matcher.find(params, top_n=20):
        assert entries[candidate.spawn_id]["lanes"]["left"]["count"] >= 1
    leftmost = [e["spawn_id"] for e in matcher.entries
                if e["context"] == "highway" and e["lanes"]["left"]["count"] == 0]
    assert leftmost
    assert all(any(r.constraint == "left_lane" for r in matcher.last_rejections[i])
               for i in leftmost)


def test_free_ride_slots_stand_in_their_lanes(matcher):
    params = highway("FRF", npc_distance_m=None, sides=("right", "left"),
                     center_present=True, center_distance_m=35.0, center_speed_ms=31.0,
                     right_present=True, right_distance_m=20.0, right_speed_ms=25.0,
                     left_present=True, left_distance_m=50.0, left_speed_ms=30.0, has_npc=True,
                     gap_ahead_m=50.0)
    # t = 0: 1 m/s faster for 2 s starts 2 m nearer, 5 m/s slower 10 m further, as fast as is
    starts = {"center": 33.0, "right": 30.0, "left": 50.0}
    result = matcher.assign(params, 2)
    assert "npc_x" not in result
    ego = matcher.network.key_at(result["ego_road_id"], result["ego_lane_id"], result["ego_s"])
    for slot, lane in (("center", ego.lane_id),
                       ("right", matcher.network.neighbour(ego, "right").lane_id),
                       ("left", matcher.network.neighbour(ego, "left").lane_id)):
        back = matcher.network.advance(result[f"{slot}_road_id"], result[f"{slot}_lane_id"],
                                       result[f"{slot}_s"], -starts[slot])
        assert back.lane_id == lane and back.s == pytest.approx(result["ego_s"], abs=1e-3)


def test_required_length_counts_the_distance_until_the_stop_trigger(matcher):
    # 30 m/s for 2.5 x (2 + 4) s = 450 m plus the gap: no spawn may see a light in that reach
    params = highway("BRAKE", npc_distance_m=60.0)
    for candidate in matcher.find(params, top_n=50):
        signal = candidate.entry["drivable"]["signal_ahead_m"]
        assert signal is None or signal > 60.0 + 30.0 * 15.0
    rejected = [r for reasons in matcher.last_rejections.values() for r in reasons]
    assert any(r.constraint == "traffic_light_on_route" for r in rejected)


def test_no_spawn_fits_names_scenario_and_constraint(matcher):
    params = highway("BRAKE", ego_ms=400.0)  # 400 m/s x 15 s is beyond every drivable length
    with pytest.raises(NoSpawnFits, match=r"BRAKE_B0_test_row000001 .*length_ahead"):
        matcher.find(params)


def test_urban_stop_at_red_follows_table_5_3(matcher):
    params = urban("U4_1", tfl_ds_m=45.0)
    candidates = matcher.find(params, top_n=5)
    for candidate in candidates:
        entry = candidate.entry
        assert entry["context"] == "urban"
        assert "stop_at_tfl_red" in entry["annotations"]["suitable_for"]
        light = next(x for x in entry["surroundings"]["traffic_lights"]
                     if "straight" in x["movements"])
        expected = (30 + max(0, 20 - abs(entry["surroundings"]["speed_limit_kmh"] - 50))
                    + max(0, 30 - abs(light["distance_m"] - 45.0))
                    + 10 * entry["annotations"]["priority"] + 15)
        assert candidate.score == pytest.approx(expected)
    near = matcher.find(urban("U4_1", tfl_ds_m=20.0), top_n=1)[0]
    far = matcher.find(urban("U4_1", tfl_ds_m=120.0), top_n=1)[0]
    assert (near.entry["surroundings"]["traffic_lights"][0]["distance_m"]
            < far.entry["surroundings"]["traffic_lights"][0]["distance_m"])


def test_urban_assignment_names_the_controlling_light(matcher):
    result = matcher.assign(urban("U4_4", tfl_ds_m=30.0), 1)
    entry = _by_id(matcher)[result["spawn_id"]]
    right_lights = [light for light in entry["surroundings"]["traffic_lights"]
                    if "right" in light["movements"]]
    assert (result["tfl_x_carla"], result["tfl_y_carla"]) == (right_lights[0]["x"],
                                                              right_lights[0]["y"])
    assert result["spawn_stop_line_distance_m"] == entry["surroundings"]["stop_line_distance_m"]
    assert result["spawn_tfl_distance_m"] == right_lights[0]["distance_m"]
    assert result["ego_y"] == -entry["transform"]["y"]


def test_in_lane_driving_without_a_light_prefers_room_before_the_next_light(matcher):
    params = urban("U1_1", tfl_ds_m=None, drive_distance_m=80.0)
    candidates = matcher.find(params, top_n=5)
    for candidate in candidates:
        assert candidate.entry["drivable"]["ahead_m"] >= 20.0 * 9.0
        assert candidate.entry["surroundings"]["stop_line_distance_m"] >= 86.0
    short = matcher.find({**params, "drive_distance_m": 10.0}, top_n=200)
    assert min(c.entry["surroundings"]["stop_line_distance_m"] for c in short) < 86.0


def test_bad_params_are_one_clear_error(matcher):
    params = highway("BRAKE")
    del params["max_speed_ms"]
    with pytest.raises(ParamsError, match="BRAKE_B0_test_row000001.*max_speed_ms"):
        matcher.find(params)
    with pytest.raises(ParamsError, match="domain"):
        matcher.find({**highway("BRAKE"), "domain": "rural"})
    with pytest.raises(ParamsError, match="gap_ahead_m='far'"):
        matcher.find({**highway("BRAKE"), "gap_ahead_m": "far"})


@pytest.mark.parametrize("code", ["U4_3", "U4_4"])
def test_a_class_passing_its_stop_line_spawns_where_the_recorded_drive_crosses_it(
        matcher, code):
    """Issue 36: the stop line lies no farther ahead than the recorded drive takes the ego's
    front (else the replay's REPLAY_NO_PASS); a drive too short for any line is one error."""
    params = urban(code, tfl_ds_m=30.0, drive_distance_m=45.0)
    reach = 45.0 - ego_front_m()
    candidates = matcher.find(params, top_n=500)
    assert candidates
    for candidate in candidates:
        assert candidate.entry["surroundings"]["stop_line_distance_m"] <= reach
    with pytest.raises(NoSpawnFits, match=rf"{code}.*stop_line_reach"):
        matcher.find({**params, "drive_distance_m": 3.0})
    assert matcher.find(urban("U4_1", drive_distance_m=3.0), top_n=1)  # it stops: no pass

"""For every record of the sample data, the assigned spawn fits the manoeuvre.

The fit is checked on the map itself (lane graph walks), not on the database's own numbers.
"""

from __future__ import annotations

import math
from collections import Counter

import pytest

from scenweave import maneuvers
from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.ingest.samples import write_highway_samples, write_urban_samples
from scenweave.ingest.variants import NotAsked, vary
from scenweave.roads import traffic_lights_carla
from scenweave.roads.road_network import LanePoint
from scenweave.roads.signals import junction_approach
from scenweave.spawn_db import NoSpawnFits, SpawnMatcher

PER_CLASS = 12


def _segments_within(network, road_id, lane_id, s, distance):
    """``(segment, metres to its end)`` from a lane position until ``distance`` is covered."""
    covered = 0.0
    for segment in network.walk(road_id, lane_id, s, forward=True):
        covered += segment.length
        yield segment, covered
        if covered >= distance:
            return


def _start_gap(params: dict, actor: str) -> float:
    """Where ``actor`` stands ahead of the ego at t = 0: its recorded gap at the manoeuvre
    start, less what it gains on the ego (both at their start speeds) before then."""
    gain = (params[f"{actor}_speed_ms"] - params["ego_speed_ms"]) * params["maneuver_start_s"]
    return params[f"{actor}_distance_m"] - gain


@pytest.fixture(scope="module")
def assigned(tmp_path_factory) -> list[tuple[dict, dict]]:
    raw = tmp_path_factory.mktemp("spawn_samples")
    write_highway_samples(raw / "highway", seed=11, per_class=PER_CLASS)
    write_urban_samples(raw / "urban", seed=11, per_class=PER_CLASS)
    report = IngestReport()
    params = [extract_params(item.record) for item in iter_raw_records(raw, report)]
    matcher = SpawnMatcher()
    per_class: Counter = Counter()
    pairs = []
    for p in params:
        pairs.append((p, matcher.assign(p, per_class[p["maneuver_class"]])))
        per_class[p["maneuver_class"]] += 1
    return pairs


def test_every_class_of_the_sample_data_is_placed(assigned):
    classes = Counter(p["maneuver_class"] for p, _ in assigned)
    assert sorted(classes) == maneuvers.codes() and min(classes.values()) >= PER_CLASS - 2


def test_highway_spawns_fit_the_manoeuvre(assigned, town04):
    for params, result in assigned:
        if params["domain"] == "highway":
            _assert_highway_fit(params, result, town04)


def test_the_record_one_lane_over_fits_the_neighbouring_lane(assigned, town04):
    """``spawns_beside`` (lane variants): the ego in a same-direction lane beside its own, and
    the whole record fits there as ``assign`` makes it fit."""
    matcher, moved, no_room = SpawnMatcher(), 0, []
    for params, result in assigned:
        if params["domain"] != "highway":
            continue
        try:
            over = matcher.place(result, matcher.spawns_beside(result)[0])
        except NoSpawnFits as err:
            no_room.append(str(err))
            continue
        here = town04.key_at(result["ego_road_id"], result["ego_lane_id"], result["ego_s"])
        beside = {town04.neighbour(here, side) for side in ("left", "right")} - {None}
        assert (str(over["ego_road_id"]), over["ego_lane_id"]) in {
            (key.road_id, key.lane_id) for key in beside}, params["scenario_id"]
        _assert_highway_fit(params, over, town04)
        moved += 1
    assert moved > 100 and len(no_room) < moved / 10, no_room
    assert all("no spawn point beside road" in message for message in no_room)


def test_background_traffic_keeps_to_a_lane_the_record_leaves_free(assigned, town04):
    """``lane_free_of_record`` (traffic variants, ``ingest.variants.vary``): beside the ego in
    its direction, in no lane an actor starts in or a manoeuvre needs, with lane for the whole
    drive."""
    matcher, placed = SpawnMatcher(), 0
    for params, result in assigned:
        if params["domain"] != "highway":
            continue
        try:
            added = vary(result, "traffic", 0, matcher)
        except NotAsked:
            continue
        here = town04.key_at(result["ego_road_id"], result["ego_lane_id"], result["ego_s"])
        used = {result[f"{a}_lane_id"] for a in ("ego", "npc", "center", "right", "left")
                if result.get(f"{a}_lane_id") is not None}
        used |= {town04.neighbour(here, side).lane_id for side in params["required_lane_sides"]}
        lane = added["background_lane_id"]
        assert lane not in used and lane * result["ego_lane_id"] > 0, params["scenario_id"]
        assert added["background_speed_ms"] == result["ego_speed_ms"]
        drive = result["ego_speed_ms"] * params["timeout_s"]
        assert town04.drivable_length(str(added["background_road_id"]), lane,
                                      added["background_s"], True, drive) >= drive
        placed += 1
    assert placed > 100


def test_a_changed_record_is_placed_anew_from_the_spawn_it_names(assigned):
    matcher = SpawnMatcher()
    params, result = next((p, r) for p, r in assigned if p["maneuver_class"] == "BRAKE")
    farther = {**result, "npc_distance_m": result["npc_distance_m"] + 5.0}
    again = matcher.place(farther, matcher.named_spawn(farther))
    assert again["spawn_id"] == result["spawn_id"] and again["ego_s"] == result["ego_s"]
    assert again["npc_s"] != result["npc_s"]
    _assert_highway_fit({**params, "npc_distance_m": farther["npc_distance_m"]}, again,
                        matcher.network)


def _assert_highway_fit(params: dict, result: dict, town04) -> None:
    ego = (str(result["ego_road_id"]), result["ego_lane_id"], result["ego_s"])
    key = town04.key_at(*ego)
    assert town04.road(ego[0]).sections[key.section].lanes[ego[1]].type == "driving"
    needed = params["gap_ahead_m"] + params["max_speed_ms"] * params["timeout_s"]
    assert town04.drivable_length(*ego, forward=True, cap=needed + 1) > needed
    assert town04.drivable_length(*ego, forward=False, cap=1000) > params["gap_behind_m"]
    # the side lanes last until the manoeuvre ends, and no light stands in the way
    manoeuvre_end = params["maneuver_start_s"] + params["duration_s"]
    side_needed = params["gap_ahead_m"] + params["max_speed_ms"] * manoeuvre_end
    for segment, _ in _segments_within(town04, *ego, side_needed):
        for side in params["required_lane_sides"]:
            assert town04.neighbour(segment.key, side) is not None, \
                (params["scenario_id"], side, segment.key)
    for segment, to_end in _segments_within(town04, *ego, needed):
        approach = junction_approach(town04, segment.key)
        assert to_end >= needed or approach is None or not approach.signalised, \
            (params["scenario_id"], "traffic light inside the drive", segment.key)
    for actor in ("npc", "center", "right", "left"):
        if f"{actor}_s" not in result:
            continue
        back = town04.advance(str(result[f"{actor}_road_id"]), result[f"{actor}_lane_id"],
                              result[f"{actor}_s"], -_start_gap(params, actor))
        assert back.s == pytest.approx(ego[2], abs=1e-3), params["scenario_id"]
        assert back.road_id == ego[0]


def test_cut_ins_start_beside_the_ego_and_others_behind_or_ahead_of_it(assigned, town04):
    for params, result in assigned:
        if params["domain"] != "highway" or not params["has_npc"] \
                or params["maneuver_class"] in ("FRF", "FRB"):
            continue
        ego = town04.key_at(result["ego_road_id"], result["ego_lane_id"], result["ego_s"])
        back = town04.advance(result["npc_road_id"], result["npc_lane_id"], result["npc_s"],
                              -_start_gap(params, "npc"))
        if params["maneuver_class"] in ("CINF", "CINB"):
            side = params["required_lane_sides"][0]
            assert back.lane_id == town04.neighbour(ego, side).lane_id
        else:
            assert back.lane_id == ego.lane_id


def test_urban_spawns_fit_the_manoeuvre(assigned, town04):
    lights = list(traffic_lights_carla().values())
    for params, result in assigned:
        if params["domain"] != "urban":
            continue
        key = town04.key_at(result["ego_road_id"], result["ego_lane_id"], result["ego_s"])
        assert not town04.road(key.road_id).in_junction
        if params["maneuver_tag"] == "in_lane_driving":
            needed = params["max_speed_ms"] * params["timeout_s"]
            assert town04.drivable_length(*key[::2], result["ego_s"], forward=True,
                                          cap=needed + 1) > needed
            continue
        # the light named in the params is a dynamic signal of the map (so pos=x,y resolves)
        nearest = min(math.hypot(x - result["tfl_x_carla"], y - result["tfl_y_carla"])
                      for x, y in lights)
        assert nearest < 1e-3
        last = town04.road(key.road_id).sections
        approach = junction_approach(town04, key._replace(
            section=len(last) - 1 if key.lane_id < 0 else 0))
        movements = {m.movement for m in approach.movements if m.signal is not None}
        needed = "right" if params["maneuver_tag"] == "turn_right_at_tfl_green" else "straight"
        assert needed in movements, params["scenario_id"]
        assert result["spawn_stop_line_distance_m"] > 0


def test_right_turn_exit_is_in_the_lane_the_right_movement_leads_to(assigned, town04):
    """U4_4: ``turn_exit_*`` lies 10 m into a successor of a connecting lane whose movement
    out of the ego's approach is ``right``, and its pose is that lane's centre."""
    turns = [(p, r) for p, r in assigned if p["maneuver_tag"] == "turn_right_at_tfl_green"]
    assert turns
    for params, result in turns:
        key = town04.key_at(result["ego_road_id"], result["ego_lane_id"], result["ego_s"])
        sections = town04.road(key.road_id).sections
        approach = junction_approach(town04, key._replace(
            section=len(sections) - 1 if key.lane_id < 0 else 0))
        exits = {successor for movement in approach.movements if movement.movement == "right"
                 for successor in town04.successors(movement.connecting_lane)}
        exit_point = (str(result["turn_exit_road_id"]), result["turn_exit_lane_id"],
                      result["turn_exit_s"])
        entries = [LanePoint(e.road_id, e.lane_id, town04.entry_s(e)) for e in exits]
        into = [town04.distance_between(entry, LanePoint(*exit_point), 50.0) for entry in entries]
        assert any(d is not None and d == pytest.approx(10.0, abs=1e-3) for d in into), \
            (params["scenario_id"], exit_point, exits)
        pose = town04.lane_to_world(*exit_point)
        assert (result["turn_exit_x"], result["turn_exit_y"], result["turn_exit_h"]) == \
            pytest.approx((pose.x, pose.y, pose.h), abs=1e-3)
    other = next(r for p, r in assigned if p["maneuver_tag"] == "straight_tfl_green")
    assert other["turn_exit_x"] is None and other["turn_exit_road_id"] is None


def test_find_stops_early_yet_ranks_as_a_full_scan(assigned):
    # find() stops walking the spawns once none left can reach the top N; a top_n larger than
    # the database scores every spawn, so both must give the same first five
    matcher = SpawnMatcher()
    for params, _ in assigned:
        full = [c.spawn_id for c in matcher.find(params, top_n=10_000)[:5]]
        assert [c.spawn_id for c in matcher.find(params, top_n=5)] == full, params["scenario_id"]

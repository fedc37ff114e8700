"""The generated Town04 spawn database: reproducible, valid, and every spawn on a driving lane."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from scenweave.roads import DEFAULT_MAP_PATH
from scenweave.roads.lanes import lane_border_offsets
from scenweave.roads.signals import is_traffic_light, signal_position
from scenweave.spawn_db import (
    DEFAULT_DB_PATH,
    SpawnDatabaseError,
    build_database,
    carry_reviews,
    load_database,
    mark_reviewed,
    write_database,
)
from scenweave.spawn_db.database import DATABASE_SCHEMA, validate_database


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory):
    path = tmp_path_factory.mktemp("spawn_db") / "Town04.json"
    database = build_database(DEFAULT_MAP_PATH)
    carry_reviews(database, load_database(DEFAULT_DB_PATH))  # people's reviews are not rebuilt
    write_database(database, path)
    return path


def test_committed_database_is_what_the_build_makes(rebuilt):
    # deterministic (the committed file came from an earlier process) and up to date: after
    # changing spawn_db/, run `scenweave spawn-db build` and commit the JSON
    assert rebuilt.read_bytes() == DEFAULT_DB_PATH.read_bytes()


def test_database_has_both_contexts_and_appendix_d_blocks(town04_db):
    entries = town04_db["spawn_points"]
    contexts = {e["context"] for e in entries}
    assert contexts == {"highway", "urban"}
    assert sum(e["context"] == "urban" for e in entries) >= 100
    assert town04_db["metadata"]["map"] == "Carla/Maps/Town04"
    for entry in entries:
        assert entry["features"]["is_straight"] != entry["features"]["is_curve"]


def test_every_spawn_lies_on_a_driving_lane(town04, town04_db):
    for entry in town04_db["spawn_points"]:
        geometry, transform = entry["geometry"], entry["transform"]
        road = town04.road(geometry["road_id"])
        x, y = transform["x"], -transform["y"]  # back to the OpenDRIVE frame
        # project onto the reference line by brute force (independent of the lane maths)
        s = np.linspace(0.0, road.length, int(road.length / 0.02) + 2)
        pose = road.plan_view.pose(s)
        nearest = int(np.argmin(np.hypot(pose.x - x, pose.y - y)))
        s_found = float(s[nearest])
        t = -(x - pose.x[nearest]) * math.sin(pose.hdg[nearest]) + (
            y - pose.y[nearest]) * math.cos(pose.hdg[nearest])
        assert s_found == pytest.approx(geometry["s"], abs=0.05), entry["spawn_id"]
        section = road.sections[road.section_index(s_found)]
        lane = section.lanes[geometry["lane_id"]]
        assert lane.type == "driving"
        inner, outer = lane_border_offsets(road, section, geometry["lane_id"], np.array([s_found]))
        low, high = sorted((float(inner[0][0]), float(outer[0][0])))
        assert low + 0.5 < t < high - 0.5, entry["spawn_id"]
        # heading along traffic: right lanes along the reference line, left lanes against it
        heading = -math.radians(transform["yaw"])
        expected = pose.hdg[nearest] + (0.0 if geometry["lane_id"] < 0 else math.pi)
        assert math.cos(heading - expected) > 0.999, entry["spawn_id"]


def test_urban_lights_are_dynamic_signals_past_the_stop_line(town04, town04_db):
    lights = {}
    for road in town04.map.roads.values():
        for signal in road.signals:
            if is_traffic_light(signal):
                pose = signal_position(town04, signal)
                lights[int(signal.id)] = (pose.x, -pose.y)
    urban = [e for e in town04_db["spawn_points"] if e["context"] == "urban"]
    for entry in urban:
        assert entry["surroundings"]["traffic_lights"], entry["spawn_id"]
        stop_line = entry["surroundings"]["stop_line_distance_m"]
        geometry = entry["geometry"]
        end = town04.advance(geometry["road_id"], geometry["lane_id"], geometry["s"], stop_line)
        stop = town04.lane_to_world(*end)
        for light in entry["surroundings"]["traffic_lights"]:
            x, y = lights[light["signal_id"]]
            assert math.hypot(light["x"] - x, light["y"] - y) < 1e-3
            # Town04's poles stand 5-25 m past their stop lines
            assert 5.0 <= math.hypot(stop.x - x, -stop.y - y) <= 25.0, entry["spawn_id"]


def test_highway_entries_sit_on_multi_lane_roads(town04_db):
    for entry in town04_db["spawn_points"]:
        if entry["context"] == "highway":
            lanes = entry["lanes"]
            assert lanes["left"]["count"] + lanes["right"]["count"] >= 1
            assert entry["surroundings"]["speed_limit_kmh"] == pytest.approx(104.6)
            assert entry["annotations"]["suitable_for"] == []


def test_turn_right_suitability_needs_a_controlled_right_turn(town04_db):
    for entry in town04_db["spawn_points"]:
        movements = {m for light in entry["surroundings"]["traffic_lights"]
                     for m in light["movements"]}
        suitable = entry["annotations"]["suitable_for"]
        assert ("turn_right_at_tfl_green" in suitable) == ("right" in movements)
        assert ("stop_at_tfl_red" in suitable) == ("straight" in movements)


def test_mark_reviewed_and_undo(tmp_path):
    path = tmp_path / "db.json"
    shutil.copy(DEFAULT_DB_PATH, path)
    assert mark_reviewed(path, [1, 2, 600]) == 3
    assert mark_reviewed(path, [1]) == 0
    reviewed = {e["spawn_id"] for e in load_database(path)["spawn_points"]
                if e["annotations"]["manually_reviewed"]}
    assert reviewed == {1, 2, 600}
    assert mark_reviewed(path, [2], reviewed=False) == 1
    with pytest.raises(SpawnDatabaseError, match=r"no spawn point with spawn_id \[99999\]"):
        mark_reviewed(path, [99999])
    assert not list(tmp_path.glob(".*.tmp"))


def test_invalid_database_names_the_field(tmp_path):
    database = json.loads(DEFAULT_DB_PATH.read_text())
    database["spawn_points"][3]["geometry"]["lane_id"] = 0
    with pytest.raises(SpawnDatabaseError, match="spawn_points/3/geometry/lane_id"):
        validate_database(database, tmp_path / "x.json")
    database["spawn_points"][3]["geometry"]["lane_id"] = -1
    database["spawn_points"][4]["spawn_id"] = database["spawn_points"][3]["spawn_id"]
    with pytest.raises(SpawnDatabaseError, match="not unique"):
        validate_database(database, tmp_path / "x.json")
    with pytest.raises(SpawnDatabaseError, match="spawn-db build"):
        load_database(tmp_path / "absent.json")


def test_any_map_builds_and_matches(tmp_path):
    from scenweave.spawn_db import SpawnMatcher
    from tests.roads.synthetic_maps import two_road_chain, write
    from tests.spawn_db.contract_params import highway

    map_path = write(tmp_path, two_road_chain().replace('max="50"', 'max="120"'), "Chain.xodr")
    database = build_database(map_path)
    entries = database["spawn_points"]
    # road 1 (100 m): s = 10, 50, 90; road 2 (50 m): s = 10; lanes -1 and -2 each
    assert [(e["geometry"]["road_id"], e["geometry"]["s"]) for e in entries if
            e["geometry"]["lane_id"] == -1] == [(1, 10.0), (1, 50.0), (1, 90.0), (2, 10.0)]
    first = entries[0]
    assert first["context"] == "highway" and database["metadata"]["map"] == "Carla/Maps/Chain"
    assert first["drivable"]["ahead_m"] == pytest.approx(90.0 + 50.0 * 1.0175, abs=1e-3)
    assert first["drivable"]["behind_m"] == pytest.approx(10.0)
    assert first["lanes"]["right"] == {"count": 1, "ahead_m": first["drivable"]["ahead_m"],
                                       "behind_m": 10.0}
    assert first["lanes"]["left"]["count"] == 0
    db_path = tmp_path / "Chain.json"
    write_database(database, db_path)
    matcher = SpawnMatcher(db_path)  # finds Chain.xodr beside the database
    params = highway("BRAKE", ego_ms=5.0, npc_distance_m=10.0)  # 10 + 5 x 15 + 6 = 91 m ahead
    found = {(c.entry["geometry"]["road_id"], c.entry["geometry"]["s"])
             for c in matcher.find(params, top_n=10)}
    assert found == {(1, 10.0), (1, 50.0)}  # 140.9 and 100.9 m ahead; the others are short
    map_path.unlink()
    with pytest.raises(SpawnDatabaseError, match="Chain.xodr.*map_path="):
        SpawnMatcher(db_path)


def test_schema_of_the_database_is_a_valid_json_schema():
    from jsonschema import Draft202012Validator

    Draft202012Validator.check_schema(json.loads(DATABASE_SCHEMA.read_text()))

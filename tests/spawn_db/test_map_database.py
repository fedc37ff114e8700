"""The spawn database per map: shipped for Town04, else built once and cached under the map
file's sha256; the matcher of a map names it in the params."""

from __future__ import annotations

import hashlib
import json
import shutil

from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.roads import BUNDLED_MAPS_DIR, resolve_map
from scenweave.spawn_db import DEFAULT_DB_PATH, SpawnMatcher, spawn_database


def test_town04_uses_the_shipped_database(tmp_path):
    assert spawn_database(resolve_map("Town04"), tmp_path) == DEFAULT_DB_PATH
    assert not list(tmp_path.iterdir())


def test_a_map_database_is_built_once_and_keyed_by_the_file_hash(tmp_path):
    map_file = tmp_path / "Mine.xodr"
    shutil.copy(BUNDLED_MAPS_DIR / "Town02.xodr", map_file)
    cache = tmp_path / "cache"
    first = spawn_database(resolve_map(map_file), cache)
    assert first.name == f"Mine-{hashlib.sha256(map_file.read_bytes()).hexdigest()}.json"
    built_at = first.stat().st_mtime_ns
    assert spawn_database(resolve_map(map_file), cache) == first
    assert first.stat().st_mtime_ns == built_at, "the second use rebuilt the database"

    map_file.write_text(map_file.read_text().replace('max="25"', 'max="26"', 1))
    second = spawn_database(resolve_map(map_file), cache)
    assert second != first and second.is_file() and first.is_file()
    assert json.loads(second.read_text())["metadata"]["source_sha256"] in second.name


def test_the_matcher_of_a_map_names_it_in_the_params(tmp_path, sample_raw):
    record = next(item.record for item in iter_raw_records(sample_raw, IngestReport())
                  if item.record.get("maneuver_class") == "U4_1")
    matcher = SpawnMatcher.for_map(resolve_map("Town06"), tmp_path)
    placed = matcher.assign(extract_params(record), 0)
    assert placed["map"] == "Town06"
    assert matcher.network.road(str(placed["ego_road_id"]))  # a road of Town06

"""Maps by name or file, and the spawn database per map: shipped for Town04, else built once
and cached under the map file's sha256."""

from __future__ import annotations

import hashlib
import json
import shutil

import pytest

from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.spawn_db import (
    BUNDLED_MAPS_DIR,
    DEFAULT_DB_PATH,
    SpawnMatcher,
    UnknownMapError,
    bundled_maps,
    resolve_map,
    spawn_database,
)


def test_every_target_town_is_bundled_with_carlas_licence():
    assert {"Town01", "Town02", "Town04", "Town06", "Town07", "Town10HD"} <= set(bundled_maps())
    assert (BUNDLED_MAPS_DIR / "LICENSE-CARLA-MIT.txt").is_file()
    attribution = (BUNDLED_MAPS_DIR / "ATTRIBUTION.md").read_text()
    for name in bundled_maps():
        digest = hashlib.sha256((BUNDLED_MAPS_DIR / f"{name}.xodr").read_bytes()).hexdigest()
        assert digest in attribution, f"{name}.xodr is not attributed with its sha256"


def test_a_name_resolves_to_the_bundled_town_in_any_case():
    town = resolve_map("town06")
    assert (town.name, town.bundled, town.logic_file) == ("Town06", True, "Town06")
    assert town.path == BUNDLED_MAPS_DIR / "Town06.xodr"
    assert resolve_map(None).name == resolve_map("").name == "Town04"


def test_a_file_is_named_by_its_absolute_path(tmp_path, monkeypatch):
    shutil.copy(BUNDLED_MAPS_DIR / "Town02.xodr", tmp_path / "Mine.xodr")
    monkeypatch.chdir(tmp_path)
    mine = resolve_map("Mine.xodr")
    assert (mine.name, mine.bundled) == ("Mine", False)
    assert mine.logic_file == str(tmp_path / "Mine.xodr")  # what scenario_runner can open
    assert resolve_map(mine.logic_file) == mine


@pytest.mark.parametrize("value, says", [("Town03", "unknown map 'Town03'"),
                                         ("nowhere/Mine.xodr", "not found")])
def test_an_unknown_map_names_the_bundled_ones(value, says):
    with pytest.raises(UnknownMapError, match=says) as raised:
        resolve_map(value)
    assert "Town01, Town02, Town04, Town06, Town07, Town10HD" in str(raised.value)


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

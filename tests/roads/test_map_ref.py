"""Maps by name or file: a bundled CARLA town (with its licence) or any OpenDRIVE file."""

from __future__ import annotations

import hashlib
import shutil

import pytest

from scenweave.roads import BUNDLED_MAPS_DIR, UnknownMapError, bundled_maps, resolve_map


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

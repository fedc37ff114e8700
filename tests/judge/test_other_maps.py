"""A scenario made for another map is checked on that map: its LogicFile names it, and gaps
along the lane are measured on its roads, not on Town04's."""

from __future__ import annotations

import pytest
from lxml import etree

from scenweave import corpus
from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.judge import validate_xosc
from scenweave.judge.validate_xosc import validate_tree
from scenweave.roads import resolve_map
from scenweave.spawn_db import SpawnMatcher


@pytest.fixture(scope="module")
def town06_brake(sample_raw, tmp_path_factory):
    """The first sample BRAKE record placed on Town06 and made into a scenario."""
    folder = tmp_path_factory.mktemp("town06")
    record = next(item.record for item in iter_raw_records(sample_raw, IngestReport())
                  if item.record.get("maneuver_class") == "BRAKE")
    params = SpawnMatcher.for_map(resolve_map("Town06"), folder / "cache").assign(
        extract_params(record), 0)
    corpus.generate(params, folder / "scenario.xosc")
    return params, folder / "scenario.xosc"


def test_the_scenario_names_its_map(town06_brake):
    params, path = town06_brake
    logic = etree.parse(str(path)).getroot().find("RoadNetwork/LogicFile")
    assert params["map"] == logic.get("filepath") == "Town06"


def test_a_town06_gap_is_measured_on_town06(town06_brake):
    params, path = town06_brake
    result = validate_xosc(path, params, fix=False)
    assert result.valid, [(f.code, f.message) for f in result.errors]
    # measured on Town04's roads (what every validator did before), the same file fails
    on_town04 = validate_tree(etree.parse(str(path)), {**params, "map": "Town04"})
    assert {"FIDELITY_GAP", "FIDELITY_MAP"} <= {f.code for f in on_town04.errors}


def test_a_logic_file_naming_another_map_is_a_fidelity_error(town06_brake, tmp_path):
    params, path = town06_brake
    other = tmp_path / "scenario.xosc"
    other.write_text(path.read_text().replace('filepath="Town06"', 'filepath="Town01"'))
    found = [f for f in validate_xosc(other, params, fix=False).errors if f.code == "FIDELITY_MAP"]
    assert found and "Town01" in found[0].message and "Town06" in found[0].message

"""The params contract: one typed model (schemas/params.py), its JSON Schema, checked once
where params are made."""

from __future__ import annotations

import json

import pytest

from scenweave import maneuvers
from scenweave.ingest import extract_params
from scenweave.ingest.issues import RecordIssue
from scenweave.inputs import InputSelection, load_input
from scenweave.schemas.params import (
    REQUIRED,
    SCHEMA_PATH,
    ParamsInvalid,
    all_keys,
    check_params,
    json_schema,
    number,
)
from scenweave.spawn_db import SpawnMatcher


@pytest.fixture(scope="module")
def made(sample_raw) -> dict[str, dict]:
    """The first sample record of each class, extracted and spawned as a run does."""
    loaded = load_input(sample_raw, InputSelection(per_class=1))
    matcher = SpawnMatcher()
    return {p["maneuver_class"]: matcher.assign(p, 0) for p in loaded.params}


def test_the_committed_schema_is_the_models():
    assert json.loads(SCHEMA_PATH.read_text()) == json_schema(), (
        "regenerate it: python -m scenweave.schemas.params")


def test_every_key_docs_params_md_names_is_in_the_model():
    documented = (SCHEMA_PATH.parents[1] / "docs" / "params.md").read_text()
    missing = [key for key in all_keys() if "_" in key and key not in documented
               and not key.startswith(("center_", "right_", "left_", "lead_", "oncoming_",
                                       "turn_exit_", "npc_", "ego_"))]
    assert missing == []


def test_params_of_every_class_keep_the_contract_after_the_spawn(made):
    assert sorted(made) == maneuvers.codes()
    for params in made.values():
        check_params(params)


@pytest.mark.parametrize(("key", "value", "why"), [
    ("ego_speed_ms", "fast", "ego_speed_ms must be number"),
    ("npc_vehicle_type", "bicycle", "must be one of"),
    ("required_lane_sides", ["up"], "must be one of"),
    ("ego_speed_ms", float("nan"), "not a finite number"),
    ("spawn_id", 1.5, "spawn_id must be integer or null"),
])
def test_a_broken_key_is_named(made, key, value, why):
    with pytest.raises(ParamsInvalid, match=why) as caught:
        check_params(made["BRAKE"] | {key: value})
    assert caught.value.key.startswith(key)


@pytest.mark.parametrize("key", REQUIRED)
def test_a_missing_required_key_is_named(made, key):
    params = dict(made["BRAKE"])
    del params[key]
    with pytest.raises(ParamsInvalid, match=key):
        check_params(params)


def test_extraction_checks_what_it_makes(tmp_path):
    record = {"schema_version": "phase1.v1", "scenario_id": "BRAKE_B0_x_row000000",
              "maneuver_class": "BRAKE", "maneuver_tag": "brake", "domain": "highway",
              "has_npc": True, "npc_position": "front", "binning_version": "B0",
              "source": {"file": "x.npy", "row_index": 0}, "behavior_type": None,
              "conventions": {"gaps_between": "reference_points"},
              "params": {"ego_vel_kmh": 90.0, "lead_vel_kmh": 80.0, "duration_s": 2.0,
                         "delta_vel_kmh": -20.0, "npc_distance_m": 30.0,
                         "brake_intensity": 0.5, "other_dir_traffic": "No",
                         "lead_vehicle_type": "Tractor"}}
    with pytest.raises(RecordIssue, match="must be one of") as caught:
        extract_params(record)
    assert caught.value.field == "params.npc_vehicle_type"
    record["params"]["lead_vehicle_type"] = "Car"
    assert extract_params(record)["npc_vehicle_type"] == "car"


def test_the_one_reader_of_optional_numbers():
    assert number({"a": 2}, "a") == 2.0
    assert number({"a": None}, "a") is None
    assert number({}, "a") is None
    assert number({"a": True}, "a") is None

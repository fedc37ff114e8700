"""Real sample records end to end: MOOVE sample data -> ingest -> params -> every script.

Twice: with spawn keys filled here by hand (Town04 road 45 / an urban pose), so the corpus is
tested on its own, and with spawns from ``spawn_db.SpawnMatcher``, where the scenarios must also
pass every ``validate_xosc`` check and the ASAM quality checker.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from lxml import etree

from scenweave import corpus, spawn_db
from scenweave.corpus.retrieval import class_tags
from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.ingest.samples import write_highway_samples
from scenweave.judge import run_asam_qc, validate_xosc
from tests.corpus.conventions import assert_entities_match, assert_storyboard_matches

LANE_OF = {"ego": -3, "npc": -3, "center": -3, "right": -4, "left": -2}


def _place(params: dict) -> dict:
    """Plausible spawn keys for every actor the params mention (docs/params.md)."""
    placed = dict(params)
    if params["domain"] == "urban":
        placed |= {"ego_x": 313.2, "ego_y": 171.8, "ego_z": 0.3, "ego_h": 1.5708,
                   "tfl_x_carla": 315.04, "tfl_y_carla": -140.21, "spawn_tfl_distance_m": 31.7,
                   "spawn_stop_line_distance_m": 24.4, "turn_exit_x": 326.4,
                   "turn_exit_y": 208.9, "turn_exit_z": 0.3, "turn_exit_h": 0.0,
                   "turn_exit_road_id": 8, "turn_exit_lane_id": -1, "turn_exit_s": 10.0}
        if params.get("lead_present"):  # straight north along the ego's lane
            placed |= {"lead_x": 313.2, "lead_y": 171.8 + params["lead_distance_m"],
                       "lead_z": 0.3, "lead_h": 1.5708}
        if params.get("oncoming_present"):  # southbound in the lane beside it
            placed |= {"oncoming_x": 309.7, "oncoming_y": 171.8 + params["oncoming_distance_m"],
                       "oncoming_z": 0.3, "oncoming_h": -1.5708}
        return placed
    for actor, lane in LANE_OF.items():
        distance = 0.0
        if actor != "ego" and f"{actor}_distance_m" in params:  # where it stands at t = 0
            drift = (params[f"{actor}_speed_ms"] - params["ego_speed_ms"]) * 2.0
            distance = params[f"{actor}_distance_m"] - drift
        placed |= {f"{actor}_road_id": 45, f"{actor}_lane_id": lane,
                   f"{actor}_s": 150.0 + distance, f"{actor}_x": 150.0 + distance,
                   f"{actor}_y": 3.5 * lane, f"{actor}_z": 0.0, f"{actor}_h": 0.0}
    return placed


@pytest.fixture(scope="module")
def sample_params(sample_raw) -> list[dict]:
    report = IngestReport()
    return [_place(extract_params(item.record)) for item in iter_raw_records(sample_raw, report)]


def test_sample_data_covers_every_class(sample_params):
    assert {p["maneuver_class"] for p in sample_params} == set(class_tags())


def test_every_sample_record_becomes_a_valid_faithful_scenario(sample_params, tmp_path,
                                                               xsd_1_0):
    for params in sample_params:
        path = corpus.generate(params, tmp_path / f"{params['scenario_id']}.xosc")
        doc = etree.parse(str(path))
        assert xsd_1_0.validate(doc), (params["scenario_id"], xsd_1_0.error_log)
        assert_entities_match(doc, params)
        assert_storyboard_matches(doc, params)


@pytest.fixture(scope="module")
def pipeline_scenarios(sample_raw, tmp_path_factory) -> list[tuple[dict, Path]]:
    """The deterministic pipeline on the sample data: ingest -> spawn match -> corpus."""
    matcher = spawn_db.SpawnMatcher()
    out = tmp_path_factory.mktemp("pipeline")
    made = []
    for index, item in enumerate(iter_raw_records(sample_raw, IngestReport())):
        params = matcher.assign(extract_params(item.record), index)
        name = params["scenario_id"].replace("/", "_")
        made.append((params, corpus.generate(params, out / f"{name}.xosc")))
    return made


def test_scenarios_at_spawns_from_the_spawn_database(pipeline_scenarios, xsd_1_0):
    for params, path in pipeline_scenarios:
        doc = etree.parse(str(path))
        assert xsd_1_0.validate(doc), (params["scenario_id"], xsd_1_0.error_log)
        assert_entities_match(doc, params)
        assert_storyboard_matches(doc, params)


def test_pipeline_output_passes_every_validator_check(pipeline_scenarios):
    """Fidelity, the manoeuvre semantics (stop before the line, no rear-end, cut-in lanes,
    light timing) and the CARLA lint, with nothing to fix and not even a warning."""
    for params, path in pipeline_scenarios:
        result = validate_xosc(path, params, fix=False)
        assert result.errors == [], (params["scenario_id"], [f.to_dict() for f in result.errors])


def test_asam_quality_checker_finds_nothing_in_pipeline_output(pipeline_scenarios):
    """Two records of every class through ``qc_openscenario``."""
    seen: Counter = Counter()
    for params, path in pipeline_scenarios:
        seen[params["maneuver_class"]] += 1
        if seen[params["maneuver_class"]] <= 2:
            assert run_asam_qc(path) == [], params["scenario_id"]
    assert set(seen) == set(class_tags())


@pytest.fixture(scope="module")
def cut_ins_ahead(tmp_path_factory) -> list[tuple[dict, Path]]:
    """CINF records of a larger sample (some cutters end slower than the ego, close ahead),
    through ingest -> spawn match -> corpus."""
    raw = tmp_path_factory.mktemp("cinf_raw")
    write_highway_samples(raw, seed=11, per_class=12)
    for path in raw.iterdir():
        if not path.name.startswith("CINF_"):
            path.unlink()
    matcher = spawn_db.SpawnMatcher()
    out = tmp_path_factory.mktemp("cinf")
    made = []
    for index, item in enumerate(iter_raw_records(raw, IngestReport())):
        params = matcher.assign(extract_params(item.record), index)
        made.append((params, corpus.generate(params, out / f"{params['scenario_id']}.xosc")))
    return made


def test_ego_reacts_to_a_slower_cutter_where_holding_its_speed_collides(cut_ins_ahead):
    """The corpus before the fix: the ego kept its recorded speed behind a cutter that ended
    slower. On some sample records that runs into the cutter (SEM_COLLISION); the ego's
    reaction avoids it on all of them."""
    collided = []
    for params, path in cut_ins_ahead:
        assert validate_xosc(path, params, fix=False).errors == [], params["scenario_id"]
        tree = etree.parse(str(path))
        action = tree.find(".//Action[@name='hero_speed_change']")
        old = {"AbsoluteTargetSpeed": params["ego_end_speed_ms"],
               "SpeedActionDynamics": params["duration_s"]}
        for tag, value in old.items():
            action.find(f".//{tag}").set("value", repr(value))
        tree.find(".//Condition[@name='hero_speed_change_start']//SimulationTimeCondition").set(
            "value", repr(params["maneuver_start_s"]))
        tree.write(str(path))
        if "SEM_COLLISION" in {f.code for f in validate_xosc(path, params, fix=False).errors}:
            collided.append(params["scenario_id"])
    assert len(collided) >= 2, collided

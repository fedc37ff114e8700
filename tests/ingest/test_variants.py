"""extract_with_variants: seeded perturbed copies whose derived values stay consistent."""

from __future__ import annotations

import pytest

from scenweave.ingest import IngestReport, extract_params, extract_with_variants, iter_raw_records
from scenweave.ingest.urban import canonicalize_scene
from tests.ingest.builders import scene, write_npy


def _brake_record(tmp_path):
    write_npy(tmp_path, "BRAKE", [["108", "90", "2.0", "-36", "30.5", "0.4", "Yes", "Truck"]])
    return next(iter_raw_records(tmp_path, IngestReport())).record


def test_variants_are_seeded_numbered_and_perturbed(tmp_path):
    record = _brake_record(tmp_path)
    base = extract_params(record)
    first = extract_with_variants(record, 3, seed=5)
    again = extract_with_variants(record, 3, seed=5)
    other = extract_with_variants(record, 3, seed=6)
    assert first == again and first != other
    assert [v["scenario_id"] for v in first] == [f"{base['scenario_id']}_v0{i}" for i in (1, 2, 3)]
    assert len({v["ego_speed_ms"] for v in first}) == 3
    for v in first:
        assert abs(v["ego_speed_ms"] - base["ego_speed_ms"]) < 5 * 0.5
        assert v["npc_end_speed_ms"] == pytest.approx(
            max(v["npc_speed_ms"] + v["delta_speed_ms"], 0.0))
        assert v["timeout_s"] == pytest.approx(2.5 * (2.0 + v["duration_s"]))
        assert v["ego_end_speed_ms"] == v["ego_speed_ms"]


def test_urban_variants_keep_a_standstill_and_clamp_the_yellow_delay():
    data = scene("U4_1", [36, 36, 18, 0, 0], [0, 1, 2, 3, 4], [0, 10, 17.5, 20, 20],
                 light=(30.0, 172))
    record = canonicalize_scene(data, "U4_1/x.json")
    for v in extract_with_variants(record, 20, seed=1):
        assert v["ego_end_speed_ms"] == 0.0
        assert 1.0 <= v["yellow_delay_s"] <= 8.0
        assert v["brake_time_s"] <= v["duration_s"]

"""The sample-data generator: MOOVE formats, all classes, realistic structure, seeded."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenweave import maneuvers
from scenweave.ingest import ingest_directory, load_records
from scenweave.ingest.samples import write_highway_samples, write_urban_samples


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    root = tmp_path_factory.mktemp("sample")
    write_highway_samples(root / "highway", seed=11, per_class=200)
    write_urban_samples(root / "urban", seed=11, per_class=8)
    return root


def _table(sample, code):
    return np.load(sample / "highway" / f"{code}_BINS_VALUES.npy", allow_pickle=True)


def test_same_seed_same_bytes_other_seed_other_bytes(tmp_path):
    a = write_highway_samples(tmp_path / "a", seed=3, per_class=5)
    b = write_highway_samples(tmp_path / "b", seed=3, per_class=5)
    c = write_highway_samples(tmp_path / "c", seed=4, per_class=5)
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]
    assert [p.read_bytes() for p in a] != [p.read_bytes() for p in c]
    ua = write_urban_samples(tmp_path / "ua", seed=3, per_class=2)
    ub = write_urban_samples(tmp_path / "ub", seed=3, per_class=2)
    assert [p.read_bytes() for p in ua] == [p.read_bytes() for p in ub]


def test_highway_files_are_2d_object_arrays_of_strings_with_the_layout_widths(sample):
    widths = {"BRAKE": 8, "BR_BK": 8, "CINF": 8, "CINB": 8, "COUTF": 8, "COUTB": 8,
              "LCF": 5, "LCB": 5, "FLF": 11, "FLB": 11, "FRF": 25, "FRB": 25}
    for code, width in widths.items():
        table = _table(sample, code)
        assert table.dtype == object and table.shape == (200, width), code
        assert all(isinstance(cell, str) for cell in table.ravel()), code


def test_lane_change_speeds_are_strongly_correlated(sample):
    table = _table(sample, "LCF")
    begin, end = table[:, 0].astype(float), table[:, 1].astype(float)
    assert np.corrcoef(begin, end)[0, 1] > 0.9  # thesis Fig. 4.16


def test_free_ride_files_carry_sentinels(sample):
    table = _table(sample, "FRF")
    assert (table[:, 4] == "-1.0").any()  # centre position sentinel
    assert np.isin(table[:, 6], ["-3.6", "-1.0"]).any()  # centre speed sentinels


def test_follow_behaviours_match_their_definitions(sample):
    table = _table(sample, "FLF")
    behaviour = table[:, 9]
    gap0, gap1 = table[:, 4].astype(float), table[:, 5].astype(float)
    assert (gap0[behaviour == "B4"] > 50).all()
    assert (gap1[behaviour == "B1"] > gap0[behaviour == "B1"]).mean() > 0.9
    assert (gap1[behaviour == "B2"] < gap0[behaviour == "B2"]).mean() > 0.9


def test_urban_files_cover_what_the_pipeline_must_handle(sample):
    scenes = [json.loads(p.read_text()) for p in sorted((sample / "urban").rglob("*.json"))]
    assert {s["scenario_code"] for s in scenes} == {"U1_1", "U4_1", "U4_2", "U4_3", "U4_4"}
    climates = [f["temporal_climatic"] for s in scenes for f in s["key_times"]]
    assert any(c["precipitation"] > 0 for c in climates)
    assert any(c["day_period"] == 2 for c in climates)
    classes = {o["mobile_object_classification"] for s in scenes for f in s["key_times"]
               for o in f["obstacles"]}
    assert {1, 4} <= classes
    steps = [np.diff([f["time"] for f in s["key_times"]]) for s in scenes]
    assert any(np.ptp(d) < 1e-6 for d in steps) and any(np.ptp(d) > 0.1 for d in steps)
    for s in scenes:
        speeds = [f["ego_vehicle"]["ego_speed"] for f in s["key_times"]]
        if s["scenario_code"] == "U4_1":
            assert speeds[-1] == 0 and any(f["ego_vehicle"]["ego_brake"]
                                           for f in s["key_times"])
        if s["scenario_code"] == "U4_4":
            assert any(f["ego_vehicle"]["turning_signal_state"] == 1 and
                       f["ego_vehicle"]["steer_wheel_angle"] > 45 for f in s["key_times"])


def test_all_sample_data_ingests_cleanly(sample, tmp_path):
    report = ingest_directory(sample, tmp_path)
    assert report.issues == []
    assert sorted(report.records_by_class) == maneuvers.codes()
    assert report.records_written == (len(maneuvers.codes("highway")) * 200
                                      + len(maneuvers.codes("urban")) * 8)
    assert sum(1 for _ in load_records(tmp_path)) == report.records_written


def test_every_urban_class_gets_per_class_files_even_when_begin_times_collide(tmp_path):
    # with seed 6 the 20th U4_3 scene draws the begin time of the 13th (857.3 s); its file
    # must get a name of its own instead of being dropped
    paths = write_urban_samples(tmp_path, seed=6, per_class=20)
    for code in ("U1_1", "U4_1", "U4_2", "U4_3", "U4_4"):
        files = sorted((tmp_path / code).glob("*.json"))
        assert len(files) == 20, code
        begins = {json.loads(f.read_text())["segment"]["begin_time"] for f in files}
        assert {f"{b:.1f}.json" for b in begins} == {f.name for f in files}
    assert len(paths) == 100
    assert {"857.3.json", "857.4.json"} <= {f.name for f in (tmp_path / "U4_3").iterdir()}

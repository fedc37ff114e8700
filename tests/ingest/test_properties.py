"""Property-based tests: random rows in, the thesis rules hold on what comes out."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ingest import IngestReport, check_record, extract_params, iter_raw_records
from ingest.layouts import load_layouts
from tests.ingest.builders import write_npy

LAYOUTS = load_layouts()
speed = st.floats(0, 200, allow_nan=False).map(lambda v: f"{v:.2f}")
duration = st.floats(0.1, 30, allow_nan=False).map(lambda v: f"{v:.2f}")
signed = st.floats(-60, 60, allow_nan=False).map(lambda v: f"{v:.2f}")
yes_no = st.sampled_from(["Yes", "No"])
vehicle = st.sampled_from(["Car", "Truck", "Van", "Motorcycle"])
left_right = st.sampled_from(["Left", "Right"])

brake_row = st.tuples(speed, speed, duration, signed, st.floats(0.5, 150).map(str),
                      st.floats(0, 1).map(lambda v: f"{v:.2f}"), yes_no, vehicle)
cut_row = st.tuples(speed, signed, signed, duration, signed.filter(lambda v: float(v) != 0),
                    yes_no, left_right, vehicle)
settings_ = settings(max_examples=60, deadline=None,
                     suppress_health_check=[HealthCheck.function_scoped_fixture])


def _params(tmp_path, code, rows):
    for old in tmp_path.glob("*.npy"):
        old.unlink()
    write_npy(tmp_path, code, [list(r) for r in rows])
    report = IngestReport()
    items = list(iter_raw_records(tmp_path, report))
    for item in items:
        check_record(item.record)
    return [extract_params(i.record) for i in items], report


@settings_
@given(rows=st.lists(brake_row, min_size=1, max_size=8))
def test_brake_rules_hold_on_any_valid_row(tmp_path, rows):
    params, report = _params(tmp_path, "BRAKE", rows)
    assert report.issues == [] and len(params) == len(rows)
    for p, row in zip(params, rows, strict=True):
        assert p["npc_end_speed_ms"] == pytest.approx(
            max(float(row[1]) / 3.6 + float(row[3]) / 3.6, 0.0))
        assert p["npc_end_speed_ms"] >= 0
        assert p["timeout_s"] == pytest.approx(2.5 * (2.0 + float(row[2])))
        assert p["max_speed_ms"] >= p["ego_speed_ms"]
        assert p["gap_ahead_m"] == pytest.approx(float(row[4]))


@settings_
@given(rows=st.lists(cut_row, min_size=1, max_size=8), code=st.sampled_from(
    ["CINF", "CINB", "COUTF", "COUTB"]))
def test_cut_rows_are_kept_or_rejected_by_the_side_of_the_npc(tmp_path, rows, code):
    params, report = _params(tmp_path, code, rows)
    behind = code.endswith("B")
    wrong_side = [i for i, r in enumerate(rows) if (float(r[4]) > 0) == behind]
    assert sorted(i.row for i in report.issues) == wrong_side
    assert all(i.field == "npc_distance_m" for i in report.issues)
    for p in params:
        assert p["npc_position"] == ("behind" if behind else "front")
        assert (p["npc_distance_m"] < 0) == behind
        assert len(p["required_lane_sides"]) == 1
        moves_left = p["lane_change_direction"] == "left"
        if code.startswith("CIN"):
            assert p["required_lane_sides"] == ["right" if moves_left else "left"]
        else:
            assert p["required_lane_sides"] == [p["lane_change_direction"]]


@settings_
@given(rows=st.lists(st.lists(st.one_of(speed, st.sampled_from(["x", "nan", "", "1e999"])),
                              min_size=3, max_size=3), min_size=1, max_size=10))
def test_every_bad_cell_is_reported_and_every_good_row_survives(tmp_path, rows):
    full = [[r[0], r[1], r[2], "No", "Left"] for r in rows]
    params, report = _params(tmp_path, "LCF", full)
    bad = {(i, name) for i, r in enumerate(rows)
           for name, cell in zip(("ego_vel_begin_kmh", "ego_vel_end_kmh", "duration_s"), r,
                                 strict=True)
           if cell in ("x", "nan", "", "1e999") or (name == "duration_s" and float(cell) < 0.1)}
    assert {(i.row, i.field) for i in report.issues} == bad
    assert len(params) == len(rows) - len({row for row, _ in bad})

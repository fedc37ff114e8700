"""Dirty input: each problem is one issue naming file, row and field; the batch goes on."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from ingest import ingest_directory
from scenweave.cli import cli
from tests.ingest.builders import scene, write_npy, write_scene

GOOD_LC = [["126", "133.2", "4", "No", "Left"], ["100.8", "97.2", "3", "Yes", "Right"]]
GOOD_BRAKE = ["108", "90", "2.0", "-36", "30.5", "0.4", "Yes", "Truck"]


def _ingest(tmp_path):
    out = tmp_path / "out"
    report = ingest_directory(tmp_path / "raw", out)
    return report, out


def _records(out, folder, code):
    path = out / folder / f"{code}.json"
    return json.loads(path.read_text()) if path.exists() else []


def test_wrong_column_count_names_the_file_and_layout_and_others_go_on(tmp_path):
    write_npy(tmp_path / "raw", "BRAKE", [GOOD_BRAKE[:7]])
    write_npy(tmp_path / "raw", "LCF", GOOD_LC)
    report, out = _ingest(tmp_path)
    [issue] = report.issues
    assert issue.file == "BRAKE_BINS_VALUES.npy" and issue.row is None
    assert "7 columns" in issue.message and "8" in issue.message
    assert len(_records(out, "highway", "LCF")) == 2


@pytest.mark.parametrize("cell, words", [("abc", "not a finite number: 'abc'"),
                                         ("nan", "not a finite number"),
                                         ("inf", "not a finite number"),
                                         ("", "not a finite number")])
def test_bad_numeric_cell_costs_only_its_row(tmp_path, cell, words):
    bad = list(GOOD_BRAKE)
    bad[1] = cell
    write_npy(tmp_path / "raw", "BRAKE", [GOOD_BRAKE, bad, GOOD_BRAKE])
    report, out = _ingest(tmp_path)
    [issue] = report.issues
    assert (issue.file, issue.row, issue.field) == ("BRAKE_BINS_VALUES.npy", 1, "lead_vel_kmh")
    assert words in issue.message
    rows = [r["source"]["row_index"] for r in _records(out, "highway", "BRAKE")]
    assert rows == [0, 2]


def test_bad_enum_and_out_of_range_values(tmp_path):
    bad_direction = ["100.8", "-7.2", "3.6", "4.0", "20", "No", "Up", "Car"]
    behind_in_front_class = ["100.8", "-7.2", "3.6", "4.0", "-20", "No", "Left", "Car"]
    negative_speed = ["-5", "-7.2", "3.6", "4.0", "20", "No", "Left", "Car"]
    write_npy(tmp_path / "raw", "CINF", [bad_direction, behind_in_front_class, negative_speed])
    report, _ = _ingest(tmp_path)
    found = {(i.row, i.field) for i in report.issues}
    assert found == {(0, "direction"), (1, "npc_distance_m"), (2, "ego_vel_kmh")}
    assert any("'Up' is not one of Left, Right" in i.message for i in report.issues)


def test_empty_and_one_dimensional_arrays(tmp_path):
    raw = tmp_path / "raw"
    raw.mkdir()
    np.save(raw / "LCF_BINS_VALUES.npy", np.empty((0, 5), dtype=object), allow_pickle=True)
    np.save(raw / "LCB_BINS_VALUES.npy", np.array(["126", "133"], dtype=object),
            allow_pickle=True)
    report, _ = _ingest(tmp_path)
    messages = {i.file: i.message for i in report.issues}
    assert messages["LCF_BINS_VALUES.npy"] == "the file has no rows"
    assert "expected a 2-D array" in messages["LCB_BINS_VALUES.npy"]


def test_unknown_class_not_npy_and_hostile_pickle(tmp_path):
    raw = tmp_path / "raw"
    write_npy(raw, "XYZ", [["1"]])
    (raw / "LCB_BINS_VALUES.npy").write_text("this is not numpy")

    class Payload:
        def __reduce__(self):
            return (open, (str(tmp_path / "pwned"), "w"))

    np.save(raw / "LCF_BINS_VALUES.npy", np.array([[Payload()]], dtype=object), allow_pickle=True)
    report, _ = _ingest(tmp_path)
    messages = {i.file: i.message for i in report.issues}
    assert "unknown class 'XYZ'" in messages["XYZ_BINS_VALUES.npy"]
    assert "not a readable .npy" in messages["LCB_BINS_VALUES.npy"]
    assert "refusing to unpickle io.open" in messages["LCF_BINS_VALUES.npy"]
    assert not (tmp_path / "pwned").exists()


def test_truncated_non_utf8_and_missing_keys_in_urban_files(tmp_path):
    raw = tmp_path / "raw"
    good = scene("U4_2", [36] * 5, [0, 1, 2, 3, 4], [0, 10, 20, 30, 40], light=(40.0, 167))
    write_scene(raw, good, "1.0.json")
    text = json.dumps(good)
    (raw / "U4_2" / "2.0.json").write_text(text[: len(text) // 2])
    (raw / "U4_2" / "3.0.json").write_bytes(text.encode()[:50] + b"\xff\xfe" + text.encode()[50:])
    missing = json.loads(text)
    del missing["key_times"][2]["ego_vehicle"]["ego_speed"]
    write_scene(raw, missing, "4.0.json")
    wrong_type = json.loads(text)
    wrong_type["key_times"][1]["ego_vehicle"]["ego_speed"] = "fast"
    write_scene(raw, wrong_type, "5.0.json")
    unknown = json.loads(text)
    unknown["scenario_code"] = "U9_9"
    write_scene(raw, unknown, "6.0.json")
    report, out = _ingest(tmp_path)
    issues = {i.file: i for i in report.issues}
    assert "invalid or truncated JSON at line 1" in issues["U4_2/2.0.json"].message
    assert "not UTF-8" in issues["U4_2/3.0.json"].message
    assert issues["U4_2/4.0.json"].field == "key_times[2].ego_vehicle.ego_speed"
    assert issues["U4_2/4.0.json"].message == "missing"
    assert issues["U4_2/5.0.json"].field == "key_times[1].ego_vehicle.ego_speed"
    assert "expected number, got str" in issues["U4_2/5.0.json"].message
    assert "unknown urban class 'U9_9'" in issues["U9_9/6.0.json"].message
    assert len(_records(out, "urban", "U4_2")) == 1


def test_non_increasing_times_are_rejected(tmp_path):
    data = scene("U4_2", [36] * 3, [0, 1, 1], [0, 10, 20], light=(40.0, 167))
    write_scene(tmp_path / "raw", data)
    report, _ = _ingest(tmp_path)
    [issue] = report.issues
    assert issue.field == "key_times[2].time" and "does not increase" in issue.message


def test_strict_turns_errors_into_a_failing_exit_and_output_is_never_half_written(tmp_path):
    raw = tmp_path / "raw"
    write_npy(raw, "BRAKE", [GOOD_BRAKE, ["x"] * 8])
    write_npy(raw, "LCF", GOOD_LC)
    runner = CliRunner()
    lenient = runner.invoke(cli, ["ingest", str(raw), "--out", str(tmp_path / "a")])
    strict = runner.invoke(cli, ["ingest", str(raw), "--out", str(tmp_path / "b"), "--strict"])
    assert lenient.exit_code == 0, lenient.output
    assert strict.exit_code == 1
    assert "BRAKE_BINS_VALUES.npy, row 1, field 'ego_vel_kmh'" in lenient.output
    report = json.loads((tmp_path / "a" / "ingest_report.json").read_text())
    assert report["errors"] == 8 and report["records_by_class"] == {"BRAKE": 1, "LCF": 2}
    leftovers = [p for p in (tmp_path / "a").rglob("*") if p.name.startswith(".")]
    assert leftovers == []


def test_custom_layout_file_is_checked_and_used(tmp_path):
    layout = json.loads((__import__("ingest").layouts.DEFAULT_LAYOUT_PATH).read_text())
    columns = layout["classes"]["LCF"]["columns"]
    columns[0], columns[1] = columns[1], columns[0]  # this lab stores end speed first
    custom = tmp_path / "layout.json"
    custom.write_text(json.dumps(layout))
    write_npy(tmp_path / "raw", "LCF", [["133.2", "126", "4", "No", "Left"]])
    report = ingest_directory(tmp_path / "raw", tmp_path / "out", layout_path=custom)
    assert report.issues == []
    [record] = json.loads((tmp_path / "out" / "highway" / "LCF.json").read_text())
    assert record["params"]["ego_vel_begin_kmh"] == 126.0
    del layout["classes"]["LCF"]["columns"][0]
    custom.write_text(json.dumps(layout))
    result = CliRunner().invoke(cli, ["ingest", str(tmp_path / "raw"), "--out",
                                      str(tmp_path / "o2"), "--layout", str(custom)])
    assert result.exit_code != 0
    assert "missing required field(s) ego_vel_end_kmh" in str(result.exception)

"""Dirty input: each problem is one issue naming file, row and field; the batch goes on."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.ingest import ingest_directory
from tests.ingest.builders import obstacle, scene, write_npy, write_scene

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


def test_a_refused_row_makes_a_failing_exit_and_output_is_never_half_written(tmp_path):
    raw = tmp_path / "raw"
    write_npy(raw, "BRAKE", [GOOD_BRAKE, ["x"] * 8])
    write_npy(raw, "LCF", GOOD_LC)
    runner = CliRunner()
    refused = runner.invoke(cli, ["ingest", str(raw), "--out", str(tmp_path / "a")])
    strict = runner.invoke(cli, ["ingest", str(raw), "--out", str(tmp_path / "b"), "--strict"])
    assert refused.exit_code == strict.exit_code == 1  # --strict is the default now
    assert "refused: 1 records (8 input errors)" in refused.stderr
    assert "BRAKE_BINS_VALUES.npy, row 1, field 'ego_vel_kmh'" in refused.stderr
    report = json.loads((tmp_path / "a" / "ingest_report.json").read_text())
    assert report["errors"] == 8 and report["records_by_class"] == {"BRAKE": 1, "LCF": 2}
    leftovers = [p for p in (tmp_path / "a").rglob("*") if p.name.startswith(".")]
    assert leftovers == []


def test_custom_layout_file_is_checked_and_used(tmp_path):
    from scenweave.ingest.layouts import DEFAULT_LAYOUT_PATH

    layout = json.loads(DEFAULT_LAYOUT_PATH.read_text())
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


WAY_POINT = "environment.infrastructure.way_points[0].infrastructure_elements"


def _bad_urban(mutate) -> dict:
    data = scene("U4_2", [36] * 5, [0, 1, 2, 3, 4], [0, 10, 20, 30, 40], light=(40.0, 167),
                 obstacles=[[obstacle(7, 25.0 - i, 9.0, 10.0)] for i in range(5)])
    mutate(data)
    return data


def _set_element(data: dict, index: int, value) -> None:
    data["environment"]["infrastructure"]["way_points"][0]["infrastructure_elements"][index][
        "value"] = value


@pytest.mark.parametrize("mutate, field, words", [
    (lambda d: d["key_times"][3]["temporal_climatic"].update(precipitation="heavy"),
     "key_times[3].temporal_climatic.precipitation", "expected number, got str 'heavy'"),
    (lambda d: d["key_times"][0]["temporal_climatic"].update(day_period={"night": 1}),
     "key_times[0].temporal_climatic.day_period", "expected number, got dict"),
    (lambda d: d["key_times"][2]["obstacles"][0].update(time_to_collision=float("nan")),
     "key_times[2].obstacles[0].time_to_collision", "not a finite number"),
    (lambda d: d["key_times"][1]["ego_vehicle"].update(ego_speed="fast"),
     "key_times[1].ego_vehicle.ego_speed", "expected number, got str 'fast'"),
    (lambda d: d.update(attributes="250"), "attributes", "expected list, got str '250'"),
])
def test_a_value_the_scenario_needs_badly_typed_is_one_error_naming_file_and_field(
        tmp_path, mutate, field, words):
    raw = tmp_path / "raw"
    write_scene(raw, _bad_urban(lambda d: None), "1.0.json")
    write_scene(raw, _bad_urban(mutate), "2.0.json")
    report, out = _ingest(tmp_path)
    [issue] = report.issues
    assert (issue.file, issue.field, issue.severity) == ("U4_2/2.0.json", field, "error")
    assert words in issue.message
    assert len(_records(out, "urban", "U4_2")) == 1


@pytest.mark.parametrize("mutate, field, words", [
    (lambda d: _set_element(d, 3, "3.5"), f"{WAY_POINT}[3].value",
     "number given as text '3.5', read as 3.5"),
    (lambda d: _set_element(d, 0, "fifty"), f"{WAY_POINT}[0].value",
     "SpeedLimit: expected number, got str 'fifty'; ignored (no scenario needs it)"),
    (lambda d: _set_element(d, 0, -30), f"{WAY_POINT}[0].value",
     "SpeedLimit: -30 is below 0; ignored"),
    (lambda d: _set_element(d, 2, [2]), f"{WAY_POINT}[2].value",
     "NumberOfLanes: expected number, got list"),
    (lambda d: d["key_times"][1]["obstacles"][0].update(relative_velocity_y="0.2"),
     "key_times[1].obstacles[0].relative_velocity_y", "number given as text '0.2', read as 0.2"),
])
def test_a_value_read_in_another_form_or_not_needed_is_a_warning_and_the_record_stays(
        tmp_path, mutate, field, words):
    raw = tmp_path / "raw"
    write_scene(raw, _bad_urban(mutate), "2.0.json")
    report, out = _ingest(tmp_path)
    [issue] = report.issues
    assert (issue.file, issue.field, issue.severity) == ("U4_2/2.0.json", field, "warning")
    assert words in issue.message
    assert len(_records(out, "urban", "U4_2")) == 1


def test_null_and_boolean_climate_flags_are_accepted(tmp_path):
    def mutate(data):
        for frame in data["key_times"]:
            frame["temporal_climatic"].update(fog=False, dazzled=True, outside_temperature=None)
    write_scene(tmp_path / "raw", _bad_urban(mutate), "1.0.json")
    report, out = _ingest(tmp_path)
    assert report.issues == []
    [record] = _records(out, "urban", "U4_2")
    assert record["environment"]["fog"] is False and record["environment"]["dazzled"] is True
    assert record["environment"]["temperature_c"] is None


def test_an_unforeseen_error_in_one_file_is_an_issue_naming_it_and_the_batch_goes_on(
        tmp_path, monkeypatch):
    # stands in for a bug no check foresaw: the TTC scan fails on the second file only
    from scenweave.ingest import urban

    real_min_ttc = urban._min_ttc

    def failing_on_second(frames):
        if frames[0]["time"] == 2.0:
            raise ZeroDivisionError("float division by zero")
        return real_min_ttc(frames)

    monkeypatch.setattr(urban, "_min_ttc", failing_on_second)
    raw = tmp_path / "raw"
    for begin in (1.0, 2.0, 3.0):
        data = scene("U1_1", [36] * 3, [begin, begin + 1, begin + 2], [0, 10, 20])
        write_scene(raw, data)
    report, out = _ingest(tmp_path)
    [issue] = report.issues
    assert issue.file == "U1_1/2.0.json" and issue.row is None
    assert issue.message == ("unexpected ZeroDivisionError while reading the file: "
                             "float division by zero")
    assert len(_records(out, "urban", "U1_1")) == 2


def test_a_list_or_array_cell_in_an_enum_column_costs_only_its_row(tmp_path):
    raw = tmp_path / "raw"
    raw.mkdir()
    table = np.empty((3, 5), dtype=object)
    for i, row in enumerate([GOOD_LC[0], GOOD_LC[1], GOOD_LC[0]]):
        table[i, :] = row
    table[1, 4] = np.array(["Left", "Right"], dtype=object)
    np.save(raw / "LCF_BINS_VALUES.npy", table, allow_pickle=True)
    report, out = _ingest(tmp_path)
    [issue] = report.issues
    assert (issue.file, issue.row, issue.field) == ("LCF_BINS_VALUES.npy", 1, "direction")
    assert "is not one of Left, Right" in issue.message
    assert [r["source"]["row_index"] for r in _records(out, "highway", "LCF")] == [0, 2]

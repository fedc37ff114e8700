"""The layout file's conventions (relative-speed sign, free-ride sentinels) drive extraction.

A user corrects the sign or the sentinels in their own layout file (SPEC §2); ingest copies
them into every record, so params extracted later, from the records on disk, follow them.
"""

from __future__ import annotations

import copy
import json
import shutil

import pytest

from scenweave.ingest import (
    LayoutError,
    extract_params,
    ingest_directory,
    load_layouts,
    load_records,
)
from scenweave.ingest.layouts import DEFAULT_LAYOUT_PATH
from tests.ingest.builders import write_npy

DEFAULT = json.loads(DEFAULT_LAYOUT_PATH.read_text())
CINF_ROW = ["100.8", "-7.2", "3.6", "4.0", "20", "No", "Left", "Car"]
ABSENT = ["-1", "-1", "-3.6", "-3.6"]
#: the bundled layouts measure gaps between bumpers; params hold them between reference points:
#: a car ahead is further by the ego's front overhang (0.8 x 4.8 m) and its rear (0.2 x 3.7 m)
CAR_AHEAD = 0.8 * 4.8 + 0.2 * 3.7


def _custom(tmp_path, change) -> object:
    layout = copy.deepcopy(DEFAULT)
    change(layout["classes"])
    path = tmp_path / "my_layout.json"
    path.write_text(json.dumps(layout))
    return path


def _params_from_disk(tmp_path, code, rows, layout_path=None) -> tuple[list[dict], list[dict]]:
    raw, out = tmp_path / "raw", tmp_path / "out"
    shutil.rmtree(raw, ignore_errors=True)
    shutil.rmtree(out, ignore_errors=True)
    write_npy(raw, code, rows)
    report = ingest_directory(raw, out, layout_path=layout_path)
    assert report.issues == []
    records = list(load_records(out))
    return records, [extract_params(r) for r in records]


def _set(classes, code, key, value):
    classes[code][key] = value


def test_cinf_sign_from_a_custom_layout_changes_the_npc_speed(tmp_path):
    # bundled layout: npc = (100.8 + (-7.2)) / 3.6 = 93.6 / 3.6 = 26.0 m/s
    _, [default] = _params_from_disk(tmp_path, "CINF", [CINF_ROW])
    assert default["npc_speed_ms"] == pytest.approx(26.0)
    # the user's file says CINF's REL counts the other way: npc = (100.8 - (-7.2)) / 3.6 = 30.0,
    # its end speed 30.0 + 3.6 / 3.6 = 31.0, which is also the highest speed in the scenario
    custom = _custom(tmp_path, lambda c: _set(c, "CINF", "relative_speed_sign", -1))
    [record], [flipped] = _params_from_disk(tmp_path, "CINF", [CINF_ROW], custom)
    assert record["conventions"]["relative_speed_sign"] == -1
    assert flipped["npc_speed_ms"] == pytest.approx(30.0)
    assert flipped["npc_end_speed_ms"] == pytest.approx(31.0)
    assert flipped["max_speed_ms"] == pytest.approx(31.0)
    assert flipped["ego_speed_ms"] == pytest.approx(28.0)


def test_coutb_sign_flipped_to_plus_by_the_user(tmp_path):
    row = ["90", "18", "-7.2", "3", "-15", "No", "Right", "Car"]
    # bundled COUTB: npc = (90 - 18) / 3.6 = 20.0; with +1: (90 + 18) / 3.6 = 30.0
    assert _params_from_disk(tmp_path, "COUTB", [row])[1][0]["npc_speed_ms"] == pytest.approx(20.0)
    custom = _custom(tmp_path, lambda c: _set(c, "COUTB", "relative_speed_sign", 1))
    assert _params_from_disk(tmp_path, "COUTB", [row], custom)[1][0]["npc_speed_ms"] == \
        pytest.approx(30.0)


def test_layout_sign_must_be_plus_or_minus_one(tmp_path):
    for bad in (True, 0, "-1", None):
        custom = _custom(tmp_path, lambda c, b=bad: _set(c, "CINB", "relative_speed_sign", b))
        with pytest.raises(LayoutError, match="classes.CINB.relative_speed_sign: must be 1 or -1"):
            load_layouts(custom)


def _frf_row(center_posx: str, left_posx: str) -> list[str]:
    return ["108", "115.2", "310", "0.2", center_posx, "35", "30.0", "29.0", *ABSENT, left_posx,
            "60", "33.0", "34.0", "Car", "None", "Van", "2", "4", "10", "Right", "0.1", "130"]


def _add_position_sentinel(classes, value):
    for column in classes["FRF"]["columns"]:
        if column["name"].endswith("_posx_begin_m"):
            column["sentinels"] = [*column["sentinels"], value]


def test_free_ride_sentinels_of_a_custom_layout_rule_both_has_npc_and_the_slots(tmp_path):
    row = _frf_row("999", "999")
    [record], [params] = _params_from_disk(tmp_path, "FRF", [row])
    assert record["has_npc"] is True
    assert params["center_distance_m"] == pytest.approx(999.0 + CAR_AHEAD)
    # this lab writes 999 for 'nobody there': centre and left become absent, right already is
    custom = _custom(tmp_path, lambda c: _add_position_sentinel(c, 999.0))
    [record], [params] = _params_from_disk(tmp_path, "FRF", [row], custom)
    assert (record["has_npc"], record["npc_position"]) == (False, None)
    assert [params[f"{s}_present"] for s in ("center", "right", "left")] == [False] * 3
    assert params["center_distance_m"] == 0.0 and params["left_vehicle_type"] is None
    assert params["required_lane_sides"] == [] and params["gap_ahead_m"] == 0.0
    # only the left slot marked absent: the centre car stays, 'left' is no longer needed
    [record], [params] = _params_from_disk(tmp_path, "FRF", [_frf_row("40", "999")], custom)
    assert record["has_npc"] is True
    assert (params["center_present"], params["left_present"]) == (True, False)
    assert params["required_lane_sides"] == []
    assert params["gap_ahead_m"] == pytest.approx(40.0 + CAR_AHEAD)


def test_present_vehicle_whose_end_values_are_sentinels_keeps_its_start_values(tmp_path):
    row = _frf_row("40", "20")
    row[5], row[7] = "-1", "-3.6"  # the centre car left the sensor's range by the end
    _, [params] = _params_from_disk(tmp_path, "FRF", [row])
    assert params["center_present"] is True
    assert params["center_end_distance_m"] == pytest.approx(40.0 + CAR_AHEAD)
    assert params["center_end_speed_ms"] == pytest.approx(30.0)


def test_a_layout_says_whether_its_gaps_are_between_bumpers_or_reference_points(tmp_path):
    _, [bumpers] = _params_from_disk(tmp_path, "CINF", [CINF_ROW])
    assert bumpers["npc_distance_m"] == pytest.approx(20.0 + CAR_AHEAD)
    custom = _custom(tmp_path, lambda c: c["CINF"].update(gaps_between="reference_points"))
    [record], [reference] = _params_from_disk(tmp_path, "CINF", [CINF_ROW], custom)
    assert record["conventions"]["gaps_between"] == "reference_points"
    assert reference["npc_distance_m"] == pytest.approx(20.0)
    wrong = _custom(tmp_path, lambda c: c["CINF"].update(gaps_between="centres"))
    with pytest.raises(LayoutError, match="gaps_between"):
        load_layouts(wrong)


def test_records_without_conventions_get_the_bundled_layouts(tmp_path):
    [record], [params] = _params_from_disk(tmp_path, "CINF", [CINF_ROW])
    older = {k: v for k, v in record.items() if k != "conventions"}
    assert extract_params(older) == params
    [record], [params] = _params_from_disk(tmp_path, "FRF", [_frf_row("-1", "20")])
    older = {k: v for k, v in record.items() if k != "conventions"}
    assert extract_params(older) == params and params["center_present"] is False

"""The NGSIM table reader on the fixture (tests/mining/make_fixtures.py): feet and ft/s to SI,
front to centre, lanes, reused ids, and what it tolerates."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scenweave.mining.readers import ngsim_csv

FT = 0.3048


@pytest.fixture(scope="module")
def recording(data):
    return ngsim_csv.read(data / "ngsim_small.csv")


def _track(recording, track_id):
    return next(t for t in recording.tracks if t.id == track_id)


def test_tracks_sorted_reused_id_split_and_single_frame_dropped(recording):
    assert [t.id for t in recording.tracks] == ["10", "11", "12", "13-1", "13-2"]
    assert any("one frame only" in w for w in recording.warnings)
    second = _track(recording, "13-2")
    assert second.t[0] == pytest.approx(1.2)
    assert len(_track(recording, "13-1").t) == len(second.t) == 8


def test_units_and_centre(recording):
    lead = _track(recording, "10")
    assert recording.dt == pytest.approx(0.1)
    assert lead.length_m == pytest.approx(15 * FT) and lead.width_m == pytest.approx(6 * FT)
    # Local_Y 200 ft is the front: the centre is half of 15 ft behind it
    assert lead.s[0] == pytest.approx(200 * FT - 7.5 * FT)
    assert lead.y[0] == pytest.approx(lead.s[0]) and lead.x[0] == pytest.approx(18 * FT)
    assert lead.speed[0] == pytest.approx(44 * FT)
    assert lead.t[:3] == pytest.approx([0.0, 0.1, 0.2])
    assert lead.heading == pytest.approx(np.full(20, math.pi / 2))


def test_braking_lead_speeds_as_given(recording):
    lead = _track(recording, "10")
    # 44 ft/s until frame 1005, then 1 ft/s less per frame
    assert lead.speed[5] == pytest.approx(44 * FT)
    assert lead.speed[-1] == pytest.approx(30 * FT)
    assert np.all(np.diff(lead.s) > 0)


def test_classes(recording):
    assert [t.vehicle_type for t in recording.tracks] == [
        "car", "truck", "car", "motorcycle", "motorcycle"]


def test_lane_change_to_the_left_lowers_the_index(recording):
    changer = _track(recording, "12")
    assert list(changer.lane[[0, -1]]) == ["3", "2"]
    step = int(np.flatnonzero(np.diff(changer.lane_index))[0]) + 1
    assert changer.t[step] == pytest.approx(1.1)
    assert changer.lane_index[step - 1] == 3 and changer.lane_index[step] == 2


def _rewrite(source: Path, target: Path, edit) -> Path:
    lines = source.read_text().splitlines()
    target.write_text("\n".join(edit(lines)) + "\n")
    return target


def test_header_case_spacing_and_extra_column(data, tmp_path):
    def edit(lines):
        header = lines[0].replace("Vehicle_ID", " vehicle id ").replace("Frame_ID", "FRAME_ID")
        return [header + ",Notes"] + [line + ",x" for line in lines[1:]]

    recording = ngsim_csv.read(_rewrite(data / "ngsim_small.csv", tmp_path / "n.csv", edit))
    assert len(recording.tracks) == 5
    assert any("columns not used: notes" in w for w in recording.warnings)


def test_bad_row_is_one_warning_naming_file_and_row(data, tmp_path):
    def edit(lines):
        # line 3 of the file: vehicle 11 at frame 1000, its Local_Y made unreadable
        fields = lines[2].split(",")
        assert fields[:2] == ["11", "1000"]
        fields[5] = "abc"
        return [*lines[:2], ",".join(fields), *lines[3:], "12,1020,20"]

    recording = ngsim_csv.read(_rewrite(data / "ngsim_small.csv", tmp_path / "b.csv", edit))
    short_line = len((data / "ngsim_small.csv").read_text().splitlines()) + 1
    bad = [w for w in recording.warnings if "row" in w]
    assert any(w.startswith("b.csv: row 3:") and "abc" in w for w in bad)
    assert any(w.startswith(f"b.csv: row {short_line}: 3 fields") for w in bad)
    assert len(bad) == 2
    follower = _track(recording, "11")
    assert len(follower.t) == 19 and follower.t[0] == pytest.approx(0.1)


def test_headerless_txt_in_the_documented_order(data, tmp_path):
    def edit(lines):
        return [",".join(line.split(",")[:18]).replace(",", "  ") for line in lines[1:]]

    path = _rewrite(data / "ngsim_small.csv", tmp_path / "trajectories-0750am.txt", edit)
    assert ngsim_csv.sniff(path)
    recording = ngsim_csv.read(path)
    assert [t.id for t in recording.tracks] == ["10", "11", "12", "13-1", "13-2"]
    assert _track(recording, "10").s[0] == pytest.approx(192.5 * FT)


def test_s_grows_along_travel_in_both_directions_of_an_arterial(tmp_path):
    header = "Vehicle_ID,Frame_ID,Local_X,Local_Y,v_Length,v_Width,v_Class,v_Vel,Lane_ID,Direction"
    rows = [f"1,{f},10,{100 + 4 * f},16,6,2,40,1,2" for f in range(5)]  # northbound
    rows += [f"2,{f},-10,{300 - 4 * f},16,6,2,40,1,4" for f in range(5)]  # southbound
    path = tmp_path / "arterial.csv"
    path.write_text("\n".join([header, *rows]) + "\n")
    north, south = ngsim_csv.read(path).tracks
    assert np.all(np.diff(north.s) > 0) and np.all(np.diff(south.s) > 0)
    # the centre is behind the front in the direction of travel
    assert north.y[0] == pytest.approx((100 - 8) * FT)
    assert south.y[0] == pytest.approx((300 + 8) * FT)
    assert south.heading[0] == pytest.approx(-math.pi / 2)


def test_turn_bay_codes_have_no_lane_index(tmp_path):
    header = "Vehicle_ID,Frame_ID,Local_X,Local_Y,v_Length,v_Width,v_Class,v_Vel,Lane_ID"
    path = tmp_path / "bay.csv"
    path.write_text("\n".join([header, "1,1,10,100,16,6,2,40,2", "1,2,10,104,16,6,2,40,11"]))
    track = ngsim_csv.read(path).tracks[0]
    assert track.lane_index[0] == 2 and np.isnan(track.lane_index[1])
    assert list(track.lane) == ["2", "11"]


def test_missing_column_is_an_error(tmp_path):
    path = tmp_path / "short.csv"
    path.write_text("Vehicle_ID,Frame_ID,Local_Y\n1,1,3\n")
    with pytest.raises(ValueError, match="no column"):
        ngsim_csv.read(path)

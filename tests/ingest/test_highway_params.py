"""Hand-computed params for two records of every highway class.

Expected values are worked out from the thesis rules (Table 5.2, docs/params.md) with the
arithmetic written out, not taken from running the code.
"""

from __future__ import annotations

import pytest

from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.scenario_lib.phases import PhasedProfile, parse_phases
from tests.ingest.builders import write_npy

KMH = 3.6
# params hold reference-point gaps and the bundled layouts give bumper gaps (docs/params.md):
# a car ahead is further by the ego's front overhang (0.8 x 4.8 m) and its own rear overhang
# (0.2 x its length), one behind by the ego's rear (0.2 x 4.8) and its own front (0.8 x length)
AHEAD = {"car": 3.84 + 0.2 * 3.7, "truck": 3.84 + 0.2 * 5.2, "van": 3.84 + 0.2 * 5.9}
BEHIND = {"car": 0.96 + 0.8 * 3.7, "truck": 0.96 + 0.8 * 5.2}
BRAKE_ROWS = [["108", "90", "2.0", "-36", "30.5", "0.4", "Yes", "Truck"],
              ["72", "36", "1.0", "-54", "12", "0.9", "No", "Car"]]
BRAKE_EXPECTED = [
    dict(ego_speed_ms=30.0, npc_speed_ms=25.0, delta_speed_ms=-10.0, npc_end_speed_ms=15.0,
         ego_end_speed_ms=30.0, npc_distance_m=30.5 + AHEAD["truck"], brake_intensity=0.4,
         timeout_s=10.0, other_dir_traffic=True, npc_vehicle_type="truck",
         required_lane_sides=[], gap_ahead_m=30.5 + AHEAD["truck"], gap_behind_m=0.0,
         max_speed_ms=30.0, npc_position="front"),
    # lead_end = max(10 - 15, 0) = 0: the lead brakes to a standstill
    dict(ego_speed_ms=20.0, npc_speed_ms=10.0, npc_end_speed_ms=0.0, timeout_s=7.5,
         npc_distance_m=12.0 + AHEAD["car"], other_dir_traffic=False),
]
LC_ROWS = [["126", "133.2", "4", "No", "Left"], ["100.8", "97.2", "3", "Yes", "Right"]]
LC_EXPECTED = [
    dict(ego_speed_ms=35.0, ego_end_speed_ms=37.0, lane_change_direction="left",
         required_lane_sides=["left"], has_npc=False, npc_position=None, timeout_s=15.0,
         max_speed_ms=37.0),
    dict(ego_speed_ms=28.0, ego_end_speed_ms=27.0, lane_change_direction="right",
         required_lane_sides=["right"], timeout_s=12.5),
]
# the end gaps follow from the speeds (linear changes): a record where they do not is an issue
FL_ROWS = [["72", "54", "90", "90", "20", "80", "200", "8", "No", "B1", "Car"],
           ["108", "108", "100.8", "100.8", "60", "52", "112", "4", "Yes", "B4", "Truck"]]
FLB_ROWS = [["90", "90", "72", "54", "20", "80", "140", "8", "No", "B1", "Car"],
            ["108", "108", "100.8", "100.8", "60", "68", "112", "4", "Yes", "B4", "Truck"]]
ABSENT = ["-1", "-1", "-3.6", "-3.6"]
FRF_ROWS = [
    ["108", "115.2", "310", "0.2", "40", "35", "30.0", "29.0", *ABSENT, "20", "60", "33.0",
     "34.0", "Car", "None", "Van", "2", "4", "10", "Right", "0.1", "130"],
    ["90", "90", "250", "0", "-1", "-1", "-1.0", "-1.0", *ABSENT, *ABSENT, "None", "None",
     "None", "1", "4", "10", "Right", "0", "130"],
]
FRB_ROWS = [
    ["108", "108", "180", "0", "-30", "-25", "31", "32", "No", "6", "-50", "-40", "33",
     "33.5", *ABSENT, "Car", "Truck", "None", "2", "4", "0", "130"],
    ["72", "79.2", "110", "0.3", "-1", "-1", "-3.6", "-3.6", "Yes", "5", *ABSENT, *ABSENT,
     "None", "None", "None", "1", "3", "0", "130"],
]

CASES = {
    "BRAKE": (BRAKE_ROWS, BRAKE_EXPECTED),
    "BR_BK": (BRAKE_ROWS, BRAKE_EXPECTED),
    "CINF": ([["100.8", "-7.2", "3.6", "4.0", "20", "No", "Left", "Car"],
              ["90", "18", "-7.2", "3", "8.5", "Yes", "Right", "Van"]],
             [dict(ego_speed_ms=28.0, npc_speed_ms=26.0, npc_end_speed_ms=27.0,
                   npc_distance_m=20.0 + AHEAD["car"], lane_change_direction="left",
                   required_lane_sides=["right"], timeout_s=15.0, ego_end_speed_ms=28.0),
              dict(ego_speed_ms=25.0, npc_speed_ms=30.0, npc_end_speed_ms=28.0,
                   required_lane_sides=["left"], timeout_s=12.5, npc_vehicle_type="van")]),
    "CINB": ([["108", "7.2", "0", "5", "-25", "No", "Right", "Car"],
              ["72", "-3.6", "3.6", "2", "-40", "No", "Left", "Truck"]],
             [dict(ego_speed_ms=30.0, npc_speed_ms=32.0, npc_end_speed_ms=32.0,
                   npc_distance_m=-25.0 - BEHIND["car"], npc_position="behind",
                   required_lane_sides=["left"], gap_behind_m=25.0 + BEHIND["car"],
                   gap_ahead_m=0.0, timeout_s=17.5),
              dict(npc_speed_ms=19.0, npc_end_speed_ms=20.0, required_lane_sides=["right"],
                   gap_behind_m=40.0 + BEHIND["truck"], timeout_s=10.0)]),
    "COUTF": ([["126", "0.36", "0.72", "3", "25", "No", "Left", "Car"],
               ["54", "-0.36", "-0.36", "2", "10", "Yes", "Right", "Car"]],
              [dict(ego_speed_ms=35.0, npc_speed_ms=35.1, npc_end_speed_ms=35.3,
                    ego_end_speed_ms=36.75, required_lane_sides=["left"], timeout_s=12.5,
                    max_speed_ms=36.75),
               dict(ego_speed_ms=15.0, npc_speed_ms=14.9, npc_end_speed_ms=14.8,
                    ego_end_speed_ms=15.75, required_lane_sides=["right"])]),
    "COUTB": ([["108", "3.6", "0", "4", "-20", "No", "Left", "Car"],
               ["90", "-7.2", "0", "3", "-12", "No", "Right", "Car"]],
              [dict(ego_speed_ms=30.0, npc_speed_ms=29.0, npc_end_speed_ms=29.0,
                    ego_end_speed_ms=30.0, required_lane_sides=["left"],
                    gap_behind_m=20.0 + BEHIND["car"]),
               dict(npc_speed_ms=27.0, required_lane_sides=["right"],
                    gap_behind_m=12.0 + BEHIND["car"])]),
    "LCF": (LC_ROWS, LC_EXPECTED),
    "LCB": (LC_ROWS, LC_EXPECTED),
    "FLF": (FL_ROWS,
            [dict(ego_speed_ms=20.0, ego_end_speed_ms=15.0, npc_speed_ms=25.0,
                  npc_end_speed_ms=25.0, npc_distance_m=20.0 + AHEAD["car"],
                  npc_distance_end_m=80.0 + AHEAD["car"], npc_dist_traveled_m=200.0,
                  behavior_type="B1", timeout_s=25.0, max_speed_ms=25.0,
                  gap_ahead_m=20.0 + AHEAD["car"], npc_position="front"),
             dict(ego_speed_ms=30.0, npc_speed_ms=28.0, npc_distance_m=60.0 + AHEAD["truck"],
                  npc_distance_end_m=52.0 + AHEAD["truck"], behavior_type="B4",
                  npc_vehicle_type="truck")]),
    "FLB": (FLB_ROWS,
            [dict(npc_distance_m=-20.0 - BEHIND["car"], npc_distance_end_m=-80.0 - BEHIND["car"],
                  gap_behind_m=20.0 + BEHIND["car"], gap_ahead_m=0.0, npc_position="behind",
                  ego_speed_ms=25.0, npc_speed_ms=20.0, npc_end_speed_ms=15.0),
             dict(npc_distance_m=-60.0 - BEHIND["truck"],
                  npc_distance_end_m=-68.0 - BEHIND["truck"], behavior_type="B4")]),
    "FRF": (FRF_ROWS,
            [dict(ego_speed_ms=30.0, ego_end_speed_ms=32.0, center_present=True,
                  center_distance_m=40.0 + AHEAD["car"], center_end_distance_m=35.0 + AHEAD["car"],
                  center_speed_ms=30.0, right_present=False, right_speed_ms=0.0,
                  left_present=True, left_distance_m=20.0 + AHEAD["van"], left_end_speed_ms=34.0,
                  left_vehicle_type="van", required_lane_sides=["left"],
                  gap_ahead_m=40.0 + AHEAD["car"], max_speed_ms=34.0,
                  timeout_s=30.0, has_npc=True, driving_side="right"),
             dict(ego_speed_ms=25.0, center_present=False, right_present=False,
                  left_present=False, required_lane_sides=[], has_npc=False,
                  npc_position=None, gap_ahead_m=0.0)]),
    "FRB": (FRB_ROWS,
            [dict(ego_speed_ms=30.0, center_present=True,
                  center_distance_m=-30.0 - BEHIND["car"], right_present=True,
                  right_distance_m=-50.0 - BEHIND["truck"],
                  right_end_distance_m=-40.0 - BEHIND["truck"], right_vehicle_type="truck",
                  left_present=False, required_lane_sides=["right"],
                  gap_behind_m=50.0 + BEHIND["truck"], timeout_s=20.0,
                  npc_position="behind", other_dir_traffic=False),
             dict(ego_speed_ms=20.0, ego_end_speed_ms=22.0, has_npc=False,
                  required_lane_sides=[], other_dir_traffic=True, timeout_s=17.5)]),
}


def _params_of(tmp_path, code: str, rows: list[list[str]]) -> list[dict]:
    write_npy(tmp_path, code, rows)
    report = IngestReport()
    params = [extract_params(item.record) for item in iter_raw_records(tmp_path, report)]
    assert report.issues == []
    return params


def test_a_following_record_one_ramp_cannot_show_gets_two_phases(tmp_path):
    # the gap grows by 25 m in 8 s while the lead holds 25 m/s and the ego slows 20 -> 15:
    # one ramp makes it 84.6 m; the lead must dip in between (issue 22: it used to be refused)
    [params] = _params_of(tmp_path, "FLF", [["72", "54", "90", "90", "20", "45", "200", "8",
                                             "No", "B1", "Car"]])
    phases = params["npc_phases"]
    assert len(phases) == 2 and phases[0]["start_s"] == 2.0
    assert phases[-1]["start_s"] + phases[-1]["duration_s"] == pytest.approx(10.0)
    assert phases[-1]["target_ms"] == pytest.approx(25.0)
    npc = PhasedProfile(25.0, parse_phases(phases))
    ego_m = (20.0 + 15.0) / 2 * 8
    gained = npc.distance(10.0) - npc.distance(2.0) - ego_m
    assert params["npc_distance_m"] + gained == pytest.approx(params["npc_distance_end_m"],
                                                              abs=0.01)


def test_a_following_record_no_profile_can_show_is_an_issue(tmp_path):
    # the gap grows by 150 m in 2 s at 90 km/h: 12.5 m/s^2 more than the ego, no car does that
    write_npy(tmp_path, "FLF", [["90", "90", "90", "90", "20", "170", "200", "2", "No", "B1",
                                 "Car"]])
    report = IngestReport()
    assert list(iter_raw_records(tmp_path, report)) == []  # ingest admits what run takes
    [issue] = report.issues
    assert (issue.file, issue.row, issue.field) == ("FLF_BINS_VALUES.npy", 0,
                                                    "npc_distance_end_m")
    # 20 and 170 m between bumpers are 24.58 and 174.58 m between reference points
    assert "24.6 m to 174.6 m" in issue.message and "no speed profile fits" in issue.message
    assert "m/s^2" in issue.message


def test_a_cut_in_behind_that_would_end_beside_the_ego_is_an_issue(tmp_path):
    # 8 m between the bumpers (11.92 m between reference points), 2 m/s faster for 5 s: it
    # would end 1.92 m behind the ego's reference point, inside the ego
    write_npy(tmp_path, "CINB", [["108", "7.2", "0", "5", "-8", "No", "Right", "Car"]])
    report = IngestReport()
    assert list(iter_raw_records(tmp_path, report)) == []
    [issue] = report.issues
    assert issue.field == "npc_distance_m" and "-1.9 m from the ego" in issue.message


@pytest.mark.parametrize("code", sorted(CASES))
def test_hand_computed_params(tmp_path, code):
    rows, expected = CASES[code]
    params = _params_of(tmp_path, code, rows)
    assert len(params) == len(expected) == 2
    for row, (got, want) in enumerate(zip(params, expected, strict=True)):
        assert got["maneuver_class"] == code
        assert got["scenario_id"] == f"{code}_B0_{code}_BINS_VALUES_row{row:06d}"
        for key, value in want.items():
            if isinstance(value, float):
                assert got[key] == pytest.approx(value, abs=1e-9), key
            else:
                assert got[key] == value, key


def test_brake_and_br_bk_share_the_brake_tag(tmp_path):
    assert _params_of(tmp_path, "BR_BK", BRAKE_ROWS)[0]["maneuver_tag"] == "brake"


def test_every_highway_params_dict_has_the_contract_keys(tmp_path):
    common = {"scenario_id", "maneuver_class", "maneuver_tag", "domain", "weather_key",
              "duration_s", "maneuver_start_s", "timeout_s", "ego_speed_ms", "ego_end_speed_ms",
              "has_npc", "npc_position", "required_lane_sides", "max_speed_ms", "gap_ahead_m",
              "gap_behind_m", "spawn_id", "ego_x", "ego_y", "ego_z", "ego_h", "ego_road_id",
              "ego_lane_id", "ego_s"}
    for code, (rows, _) in CASES.items():
        for params in _params_of(tmp_path / code, code, rows):
            assert common <= params.keys(), code
            assert params["weather_key"] == "Day_Clear"
            assert params["ego_x"] is None and params["spawn_id"] is None


@pytest.mark.parametrize("code", ["FLF", "FLB"])
def test_one_bumper_clearance_ahead_and_behind(tmp_path, code):
    """Issue 22: a 2 m bumper gap at 10 km/h is playable ahead of the ego and behind it alike
    (behind it used to be refused); 0.3 m, less than MIN_BUMPER_GAP_M, is refused on both
    sides, naming the gap's field."""
    row = ["10", "10", "10", "10", "2", "2", "11.1", "4", "No", "B3", "Car"]
    write_npy(tmp_path / "ok", code, [row])
    report = IngestReport()
    assert len(list(iter_raw_records(tmp_path / "ok", report))) == 1, report.issues
    write_npy(tmp_path / "close", code, [[*row[:4], "0.3", "0.3", *row[6:]]])
    report = IngestReport()
    assert list(iter_raw_records(tmp_path / "close", report)) == []
    [issue] = report.issues
    assert issue.field == "npc_distance_begin_m" and "overlap" in issue.message

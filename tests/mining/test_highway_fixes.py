"""Each highway detector fix of issue 23 (and the measured timing of issue 22, item 5), on
recordings made from physics: one record per braking phase with its best-second intensity,
short sharp brakes kept, no brake at a track's end, lane changes that need lateral motion
and survive a flickering label, timed by that motion, series that carry what was measured,
no pair across a vehicle the file took out, and no event twice across overlapping files."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from scenweave.mining import Recording, Track
from scenweave.mining.mine import mine_recordings
from scenweave.mining.thresholds import load_thresholds
from scenweave.player import Playback
from scenweave.player.playback import Box
from tests.mining.synthetic import DT, braking, car, events_by_code, profile, recording, steady

LIMITS = load_thresholds()


def events(*tracks: Track, removed: tuple[Track, ...] = ()) -> dict[str, list]:
    rec = recording(*tracks)
    rec.removed.extend(removed)
    return events_by_code(rec)


def changer(track_id: str, duration_s: float, s0: float, v: float, lane_at: Callable,
            y_at: Callable) -> Track:
    """A car at speed ``v`` whose lane label and lateral position (y, m; lanes 3.5 m apart,
    lane n centred at -3.5 n) follow the given functions of time."""
    base = car(track_id, duration_s, s0, steady(v), 2)
    lanes = lane_at(base.t).astype(float)
    return Track(**{**base.__dict__, "y": y_at(base.t), "lane_index": lanes,
                    "lane": np.array([str(int(k)) for k in lanes], dtype=object)})


def linear_step(y0: float, y1: float, start: float, duration: float) -> Callable:
    """Sideways at a constant rate, as a scenario's lane change (linear dynamics) moves."""
    return lambda t: y0 + (y1 - y0) * np.clip((t - start) / duration, 0.0, 1.0)


def smooth_step(y0: float, y1: float, start: float, duration: float) -> Callable:
    def y(t: np.ndarray) -> np.ndarray:
        share = np.clip((t - start) / duration, 0.0, 1.0)
        return y0 + (y1 - y0) * (3 * share ** 2 - 2 * share ** 3)
    return y


# -- braking ------------------------------------------------------------------------------

def test_a_short_sharp_brake_is_kept_with_its_best_second_as_intensity():
    # 9.2 -> 6.1 m/s within one second: the rarest, most valuable brake
    lead = car("lead", 10, 40, profile((0, 9.2), (4, 9.2), (5, 6.1), (10, 6.1)), 2)
    (brake,) = events(lead, car("ego", 10, 25, steady(9.2), 2))["BR_BK"]
    assert (brake.ego, brake.npc) == ("ego", "lead")
    # 3.1 m/s lost within its best second; the 1 s smoothing takes up to a fifth off a brake
    # this short (a longer one keeps its whole best second, below)
    assert 0.8 * 3.1 / 8 - 0.01 <= brake.fields["brake_intensity"] <= 3.1 / 8 + 0.01
    assert brake.fields["delta_vel_kmh"] == pytest.approx(-3.1 * 3.6, abs=1.0)
    # the window holds the whole brake, blurred by at most the 1 s smoothing
    assert brake.start_s <= 4.0 and brake.end_s >= 5.0 and brake.fields["duration_s"] <= 2.0


def test_two_hard_stretches_of_one_braking_phase_are_one_record():
    lead = car("lead", 14, 60, profile((0, 25), (3, 25), (4.5, 19), (4.7, 18.9), (6, 12),
                                       (14, 12)), 2)
    found = events(lead, car("ego", 14, 30, steady(25), 2))
    assert len(found["BRAKE"]) == 1
    brake = found["BRAKE"][0]
    assert brake.start_s < 3.6 and brake.end_s > 5.4  # both stretches inside it
    assert brake.fields["brake_intensity"] == pytest.approx(5.3 / 8, abs=0.06)


def test_a_mild_slowdown_into_the_track_end_is_no_brake():
    # 1.5 m/s^2 until the last step: the second derivative of a fit there is no deceleration
    lead = car("lead", 8, 60, profile((0, 20), (5, 20), (8, 15.5)), 2)
    assert "BRAKE" not in events(lead, car("ego", 8, 35, steady(20), 2))


# -- lane changes ---------------------------------------------------------------------------

def test_a_flickering_lane_label_is_one_lane_change_timed_by_the_lateral_motion():
    flicker = profile((0, 2), (4.9, 2), (5.0, 1), (5.2, 1), (5.3, 2), (5.5, 2), (5.6, 1),
                      (12, 1))
    ego = changer("ego", 12, 30, 20, lambda t: np.round(flicker(t)),
                  linear_step(-7.0, -3.5, 4.0, 2.0))
    found = events(ego, car("other", 12, 70, steady(20), 1), car("slow", 12, 0, steady(20), 2))
    (change,) = found["LCF"]
    assert change.fields["direction"] == "Left"
    assert change.start_s == pytest.approx(4.0, abs=0.15)
    assert change.fields["duration_s"] == pytest.approx(2.0, abs=0.15)  # not a fixed 3.0
    assert change.series["ego_lateral_m"][-1] - change.series["ego_lateral_m"][0] > 2.5


def test_lateral_drift_with_a_lane_label_change_is_no_lane_change():
    drifter = changer("drift", 12, 30, 20, lambda t: np.where(t < 6, 2, 1),
                      smooth_step(-5.5, -4.9, 4.0, 3.0))  # 0.6 m across the line
    found = events(drifter, car("other", 12, 60, steady(20), 1), car("b", 12, 5, steady(20), 2))
    assert not found.get("LCF") and not found.get("LCB")


def test_the_series_carries_speed_position_lateral_and_lane_of_every_role():
    lead = car("lead", 10, 40, braking(15, 3, 4, 8), 2)
    (brake,) = events(lead, car("ego", 10, 20, steady(12), 2))["BR_BK"]
    series = brake.series
    n = len(series["t"])
    for role in ("ego", "npc"):
        for key in ("speed_ms", "s_m", "lateral_m", "lane"):
            assert len(series[f"{role}_{key}"]) == n
    assert series["npc_s_m"][-1] - series["npc_s_m"][0] == pytest.approx(
        sum(v * DT for v in series["npc_speed_ms"][:-1]), rel=0.05)
    assert set(series["ego_lane"]) == {2.0}


# -- pairs and duplicates ------------------------------------------------------------------

def test_no_following_pair_spans_a_vehicle_the_file_took_out():
    lead, ego = car("lead", 8, 60, steady(20), 2), car("ego", 8, 20, steady(20), 2)
    hidden = car("planned", 8, 40, steady(20), 2)
    assert "FLF" in events(lead, ego)
    found = events(lead, ego, removed=(hidden,))
    assert "FLF" not in found and "FLB" not in found


def _snippet(shift_s: float, source: str, turn_rad: float = 0.0,
             lead_decel: float = 5.0) -> Recording:
    """Steps from ``shift_s`` on of one recording (its clock restarted at 0), in a frame of
    its own: turned by ``turn_rad`` and moved (as CommonRoad puts each file's origin at its
    planning problem's start)."""
    tracks = [car("lead", 14, 60, braking(25, 4, lead_decel, 10), 2),
              car("ego", 14, 30, braking(25, 4.5, lead_decel, 10), 2)]
    first = int(round(shift_s / DT))
    cos, sin = np.cos(turn_rad), np.sin(turn_rad)
    cut = []
    for tr in tracks:
        part = {k: getattr(tr, k)[first:] for k in ("t", "x", "y", "heading", "speed", "s",
                                                     "lane", "lane_index")}
        x, y = part["x"] - 40.0, part["y"] + 7.0
        part |= {"t": np.round(part["t"] - shift_s, 3), "x": cos * x - sin * y,
                 "y": sin * x + cos * y}
        cut.append(Track(**{**tr.__dict__, **part}))
    return Recording(source=source, dt=DT, tracks=cut, reader="synthetic")


def test_an_event_in_two_overlapping_files_is_written_once(tmp_path):
    first, second = _snippet(0.0, "a.xml"), _snippet(2.0, "b.xml", turn_rad=0.5)
    report = mine_recordings([first, second], tmp_path, LIMITS)
    assert report.written["BRAKE"] == 1
    assert [(d["file"], d["class"], d["same_as_in"]) for d in report.duplicates
            if d["class"] == "BRAKE"] == [("b.xml", "BRAKE", "a.xml")]
    alone = mine_recordings([_snippet(2.0, "b.xml")], tmp_path / "alone", LIMITS)
    assert alone.written["BRAKE"] == 1  # the second file alone still has it


def test_reused_vehicle_ids_in_another_recording_are_other_events(tmp_path):
    # NGSIM reuses ids across its periods: same ids, other motion, no repeat
    other = _snippet(2.0, "b.xml", lead_decel=4.0)
    report = mine_recordings([_snippet(0.0, "a.xml"), other], tmp_path, LIMITS)
    assert report.written["BRAKE"] == 2 and not report.duplicates


# -- the round trip -----------------------------------------------------------------------

def _played_lane_change(start_s: float, duration_s: float) -> Playback:
    """The ego alone on a curved road (radius 400 m), changing from lane -2 to -1 (left)
    between ``start_s`` and ``start_s + duration_s``, as esmini reports it."""
    t = np.round(np.arange(0.0, 12.0, 0.05), 3)
    s = 20.0 * t
    t_offset = linear_step(-5.25, -1.75, start_s, duration_s)(t)  # OpenDRIVE t, + left
    radius = 400.0
    angle = s / radius
    x = (radius - t_offset) * np.sin(angle)
    y = radius - (radius - t_offset) * np.cos(angle)
    lane = np.where(t_offset > -3.5, -1, -2)
    centre = np.where(lane == -1, -1.75, -5.25)
    track = {"x": x.tolist(), "y": y.tolist(), "z": [0.0] * len(t), "h": angle.tolist(),
             "speed": [20.0] * len(t), "road": [0] * len(t), "lane": lane.tolist(),
             "s": s.tolist(), "lane_offset": (t_offset - centre).tolist(),
             "junction": [0] * len(t)}
    return Playback(times=t.tolist(), tracks={"hero": track},
                    boxes={"hero": Box(4.8, 2.0, 1.4)})


def test_an_lcb_scenario_played_alone_comes_back_as_the_same_lane_change():
    from scenweave.mining.roundtrip import round_trip

    record = {"maneuver_class": "LCB", "scenario_id": "LCB_x",
              "provenance": {"tracks": {"ego": "e"}},
              "params": {"ego_vel_begin_kmh": 72.0, "ego_vel_end_kmh": 72.0,
                         "duration_s": 2.5, "direction": "Left"}}
    trip = round_trip(record, _played_lane_change(3.0, 2.5), LIMITS)
    assert trip.found and trip.holds, trip.misses
    slower = round_trip(record, _played_lane_change(3.0, 4.0), LIMITS)
    assert slower.found and "duration_s" in slower.misses  # the timing is compared


# -- the cut-in direction convention --------------------------------------------------------

def test_a_cut_in_direction_means_the_move_unless_the_layout_says_the_side(tmp_path):
    import copy
    import json

    from scenweave.ingest import LayoutError, extract_params, ingest_directory, load_records
    from scenweave.ingest.layouts import DEFAULT_LAYOUT_PATH, load_layouts
    from tests.ingest.builders import write_npy

    row = ["100.8", "-7.2", "3.6", "4.0", "20", "No", "Left", "Car"]

    def direction(layout: dict | None, name: str) -> str:
        path = None
        if layout is not None:
            path = tmp_path / f"{name}.json"
            path.write_text(json.dumps(layout))
        write_npy(tmp_path / name, "CINF", [row])
        ingest_directory(tmp_path / name, tmp_path / f"{name}-out", layout_path=path)
        (record,) = load_records(tmp_path / f"{name}-out")
        return extract_params(record)["lane_change_direction"]

    bundled = json.loads(DEFAULT_LAYOUT_PATH.read_text())
    assert bundled["classes"]["CINF"]["direction_is"] == "move"
    assert direction(None, "bundled") == "left"  # the cutter moves left
    sides = copy.deepcopy(bundled)
    sides["classes"]["CINF"]["direction_is"] = "from_side"
    assert direction(sides, "sides") == "right"  # "Left": it comes from the ego's left
    sides["classes"]["CINF"]["direction_is"] = "up"
    (tmp_path / "bad.json").write_text(json.dumps(sides))
    with pytest.raises(LayoutError, match="classes.CINF.direction_is"):
        load_layouts(tmp_path / "bad.json")


def test_a_mined_cut_in_says_which_convention_its_direction_follows():
    from pathlib import Path

    from scenweave.mining.records import highway_record

    ego = car("ego", 12, 0, steady(25), 2)
    cutter = changer("cutter", 12, 15, 26, lambda t: np.where(t < 6, 3, 2),
                     smooth_step(-10.5, -7.0, 5.0, 2.0))
    (cin,) = events(ego, cutter)["CINF"]
    record = highway_record(cin, Path("road.xml"), "synthetic", 0)
    assert cin.fields["direction"] == "Left"
    assert record["conventions"]["direction_is"] == "move"


# -- free rides ---------------------------------------------------------------------------

def test_a_free_ride_carries_its_surrounding_cars_and_a_following_is_none():
    ego = car("ego", 8, 30, steady(20), 2)
    ahead = car("ahead", 8, 100, steady(21), 2)  # 65.5 m ahead: nobody to follow
    right = car("right", 8, 45, steady(20), 3)
    behind_left = car("behind", 8, 10, steady(20), 1)
    found = events(ego, ahead, right, behind_left)
    (frf,) = [e for e in found["FRF"] if e.ego == "ego"]
    assert frf.npc == "ahead" and frf.fields["duration_s"] == pytest.approx(8.0, abs=0.1)
    assert frf.fields["center_posx_begin_m"] == pytest.approx(70 - 4.5, abs=0.5)
    assert frf.fields["right_posx_begin_m"] == pytest.approx(15 - 4.5, abs=0.5)
    assert frf.fields["left_posx_begin_m"] == -1.0 and frf.fields["left_vehicle_type"] == "None"
    assert frf.series["center_speed_ms"][0] == pytest.approx(21, abs=0.2)
    (frb,) = [e for e in found["FRB"] if e.ego == "ego"]
    assert frb.npc is None and frb.fields["left_posx_begin_m"] == pytest.approx(15.5, abs=0.5)
    # the same ego 30 m behind a lead follows it: no free ride
    close = events(ego, car("lead", 8, 60, steady(20), 2), right, behind_left,
                   car("far", 8, 160, steady(20), 1))
    assert not [e for e in close.get("FRF", []) if e.ego == "ego"]


def test_the_car_commonroad_took_out_is_put_back_and_nobody_follows_across_it(tmp_path):
    from lxml import etree

    from scenweave.mining.readers import commonroad
    from scenweave.mining.traffic import Traffic

    fixture = Path(__file__).parent / "data" / "commonroad_small.xml"
    plain = commonroad.read(fixture)
    ids = [t.id for t in plain.tracks]
    assert Traffic(plain).leader(ids.index("1"), 0).track == ids.index("2")  # 1 follows 2
    root = etree.parse(str(fixture)).getroot()
    root.append(etree.fromstring(
        '<planningProblem id="77"><initialState><position><point><x>80</x><y>1.75</y>'
        '</point></position><velocity><exact>9</exact></velocity><orientation>'
        '<exact>3.14159</exact></orientation><time><exact>0</exact></time></initialState>'
        '<goalState><position><rectangle><length>4</length><width>2</width><orientation>'
        '3.14159</orientation><center><x>52</x><y>1.75</y></center></rectangle></position>'
        '<time><intervalStart>26</intervalStart><intervalEnd>30</intervalEnd></time>'
        '</goalState></planningProblem>'))
    path = tmp_path / "with_problem.xml"
    etree.ElementTree(root).write(str(path))
    recording = commonroad.read(path)
    (planned,) = recording.removed
    assert [t.id for t in recording.tracks] == ids  # never a track of its own
    assert planned.id == "77" and set(planned.lane_index) == {2.0}
    assert planned.s[0] == pytest.approx(-80.0) and planned.s[28] == pytest.approx(-52.0, abs=0.5)
    assert Traffic(recording).leader(ids.index("1"), 0) is None  # it drives between 1 and 2

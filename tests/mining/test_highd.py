"""The highD reader on the fixture recording 01 (tests/mining/make_fixtures.py): box centres,
s along travel in both directions, lanes ordered from the median, classes from tracksMeta."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenweave.mining.readers import highd


@pytest.fixture(scope="module")
def recording(data):
    return highd.read(data / "highd" / "01_tracks.csv")


def _track(recording, track_id):
    return next(t for t in recording.tracks if t.id == track_id)


def test_tracks_frames_and_times(recording):
    assert recording.reader == "highd" and recording.dt == pytest.approx(0.04)
    assert [t.id for t in recording.tracks] == ["1", "2", "3", "4"]  # 5: one frame only
    assert _track(recording, "1").t[:3] == pytest.approx([0.0, 0.04, 0.08])
    assert _track(recording, "4").t[0] == pytest.approx(0.08)  # from frame 3


def test_box_centre_sizes_and_classes(recording):
    car, truck = _track(recording, "1"), _track(recording, "2")
    # upper-left corner (17.75, 12.85) of a 4.5 x 1.8 box
    assert (car.x[0], car.y[0]) == pytest.approx((20.0, 13.75))
    assert (car.length_m, car.width_m, car.vehicle_type) == (4.5, 1.8, "car")
    assert (truck.length_m, truck.width_m, truck.vehicle_type) == (12.0, 2.5, "truck")


def test_s_grows_along_travel_in_both_directions(recording):
    for track in recording.tracks:
        assert np.all(np.diff(track.s) > 0), track.id
    towards_minus_x = _track(recording, "3")
    assert towards_minus_x.s[0] == pytest.approx(-300.0)
    assert towards_minus_x.s[1] - towards_minus_x.s[0] == pytest.approx(30.0 * 0.04)
    assert towards_minus_x.heading[0] == pytest.approx(math.pi)


def test_heading_and_speed_from_the_velocity(recording):
    truck = _track(recording, "2")
    vy = -3.5 / 9 * 25  # it moves up the image by one lane in 9 frames
    assert truck.speed[0] == pytest.approx(math.hypot(22.0, vy), abs=1e-3)
    assert truck.heading[0] == pytest.approx(math.atan2(vy, 22.0), abs=1e-3)


def test_lane_index_counts_from_the_median(recording):
    # lower half (towards +x): lane 5 is next to the median -> 1; upper half: lane 3 -> 1
    assert set(_track(recording, "1").lane_index) == {1.0}
    assert set(_track(recording, "3").lane_index) == {1.0}
    assert set(_track(recording, "4").lane_index) == {2.0}
    truck = _track(recording, "2")
    assert list(truck.lane[[0, -1]]) == ["6", "5"]
    assert list(truck.lane_index[[0, -1]]) == [2.0, 1.0]  # a change to the left


def test_lane_order_from_markings():
    upper, lower = np.array([1.0, 4.5, 8.0, 11.5]), np.array([14.0, 17.5, 21.0])
    order = highd.lane_order({2: 2.0, 3: 6.0, 4: 10.0, 6: 15.0, 7: 20.0, 9: 30.0}, upper, lower)
    assert order[2] == 3 and order[3] == 2 and order[4] == 1
    assert order[6] == 1 and order[7] == 2 and math.isnan(order[9])


def test_a_pedestrian_class_is_skipped_and_counted(data, tmp_path):
    for name in ("tracks", "tracksMeta", "recordingMeta"):
        text = (data / "highd" / f"01_{name}.csv").read_text()
        if name == "tracksMeta":
            text = text.replace(",Car,1,", ",Pedestrian,1,", 1)
        (tmp_path / f"07_{name}.csv").write_text(text)
    recording = highd.read(tmp_path / "07_tracks.csv")
    assert [t.id for t in recording.tracks] == ["1", "2", "4"]
    assert recording.warnings == ["skipped road users that are not vehicles: 1 pedestrian"]


def test_sniff_and_companions(data):
    assert highd.sniff(data / "highd" / "01_tracks.csv")
    assert not highd.sniff(data / "highd" / "01_tracksMeta.csv")
    assert highd.companion(data / "highd" / "01_recordingMeta.csv")
    assert not highd.sniff(data / "ngsim_small.csv")

"""The CommonRoad reader on the fixture scenario (tests/mining/make_fixtures.py): a two-lane
road running towards -x to a signalised stop line at x = 0."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenweave.mining.readers import commonroad
from scenweave.mining.tracks import LightPhase


@pytest.fixture(scope="module")
def recording(data):
    return commonroad.read(data / "commonroad_small.xml")


def _track(recording, track_id):
    return next(t for t in recording.tracks if t.id == track_id)


def test_vehicles_types_and_skipped_road_users(recording):
    assert recording.reader == "commonroad" and recording.dt == pytest.approx(0.1)
    assert [(t.id, t.vehicle_type) for t in recording.tracks] == [
        ("1", "car"), ("2", "car"), ("3", "truck")]  # the bus is a truck
    assert recording.warnings == [
        "commonroad_small.xml: skipped road users that are not vehicles: 1 pedestrian"]
    bus = _track(recording, "3")
    assert (bus.length_m, bus.width_m) == (12.0, 2.5)


def test_states_as_given(recording):
    car = _track(recording, "1")
    assert len(car.t) == 30 and car.t[-1] == pytest.approx(2.9)
    assert (car.x[0], car.y[0]) == (90.0, 1.75)
    assert car.speed == pytest.approx(np.full(30, 10.0))
    assert car.heading[0] == pytest.approx(math.pi)


def test_s_runs_along_traffic(recording):
    car = _track(recording, "1")
    # the road runs towards -x: s = -x
    assert car.s == pytest.approx(-car.x)
    behind = _track(recording, "3")
    assert np.all(np.diff(behind.s) > 0)


def test_lanes_and_a_change_to_the_left(recording):
    car, changer = _track(recording, "1"), _track(recording, "2")
    assert set(car.lane) == {"101"} and set(car.lane_index) == {2.0}
    assert list(changer.lane[[0, -1]]) == ["101", "100"]
    assert list(changer.lane_index[[0, -1]]) == [2.0, 1.0]
    # it crosses y = 0 (the lane boundary) at step 15
    step = int(np.flatnonzero(np.diff(changer.lane_index))[0]) + 1
    assert changer.y[step - 1] > 0 >= changer.y[step]


def test_traffic_light(recording):
    (light,) = recording.lights
    assert light.id == "200" and light.lanes == ("100", "101")
    assert light.stop_line_s == pytest.approx(0.0)  # both lanelets end at x = 0
    # green 10 steps, yellow 5, red 10 + redYellow 3 (one red), inactive 2 (left out)
    assert light.phases == (LightPhase(0.0, 1.0, "green"), LightPhase(1.0, 1.5, "yellow"),
                            LightPhase(1.5, 2.8, "red"))


def test_direction_groups_split_opposite_directions():
    directions = np.array([[1.0, 0.0], [0.98, 0.199], [-1.0, 0.0], [0.0, 1.0]])
    group, axes = commonroad.direction_groups(directions, np.array([10.0, 5.0, 8.0, 1.0]))
    assert group[0] == group[1] != group[2] != group[3]
    assert axes[group[2]] == pytest.approx([-1.0, 0.0])
    assert axes[group[0]][1] > 0  # the mean of the two, weighted by length


def test_the_library_reader_gives_the_same_tracks(data, monkeypatch, recording):
    """Where the fast lxml path cannot read an obstacle the library reads the whole file."""
    monkeypatch.setattr(commonroad, "_parsed_raws", lambda root: None)
    slow = commonroad.read(data / "commonroad_small.xml")
    assert [t.id for t in slow.tracks] == [t.id for t in recording.tracks]
    for fast_track, slow_track in zip(recording.tracks, slow.tracks, strict=True):
        for name in ("t", "x", "y", "heading", "speed", "s", "lane_index"):
            assert getattr(slow_track, name) == pytest.approx(getattr(fast_track, name))
        assert list(slow_track.lane) == list(fast_track.lane)
    assert slow.warnings == recording.warnings


def test_sniff(data):
    assert commonroad.sniff(data / "commonroad_small.xml")
    assert not commonroad.sniff(data / "ngsim_small.csv")

"""A free ride measured over a given window (``mining.roundtrip`` measures a replay over the
record's own window) where the ego was not seen for all of it: a replay esmini ended early.
Found by the type check (issue 21): the step at the window's end was ``None``, and indexing a
speed array with ``None`` adds an axis instead of failing, so the event broke later with a
TypeError."""

from __future__ import annotations

from scenweave.mining.highway import free_ride_event
from scenweave.mining.scene import Scene
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import car, recording, steady

LIMITS = load_thresholds()


def _scene() -> Scene:
    ego = car("ego", 5, 30, steady(20), 2)  # seen 0..5 s
    right = car("right", 8, 45, steady(20), 3)  # a surrounding car 10.5 m ahead, right
    return Scene(recording(ego, right), LIMITS)


def test_a_free_ride_window_past_the_end_of_the_ego_track_is_no_event():
    assert free_ride_event(_scene(), "FRF", 0, 1.0, 8.0, True, LIMITS["free_ride"]) is None


def test_a_free_ride_window_before_the_ego_track_is_no_event():
    late = car("ego", 5, 30, steady(20), 2)
    late = type(late)(**{**late.__dict__, "t": late.t + 3.0})  # seen 3..8 s
    scene = Scene(recording(late, car("right", 8, 45, steady(20), 3)), LIMITS)
    assert free_ride_event(scene, "FRF", 0, 1.0, 6.0, True, LIMITS["free_ride"]) is None


def test_the_same_window_inside_the_ego_track_is_a_free_ride():
    event = free_ride_event(_scene(), "FRF", 0, 1.0, 4.0, True, LIMITS["free_ride"])
    assert event is not None and event.ego == "ego"
    assert event.fields["right_vehicle_type"] == "Car"

"""Issue 32: what the detectors must not take for an event, on recordings made from physics.

A lane label that flips without the car crossing the line is no lane change; a tracker's
sag-and-snap of a speed is no brake, and a spike inside a real brake does not split it; an
ego standing all along has no braking lead; in town a car ahead on the ego's path, inside a
junction's lanelet, still ends a free ride.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from scenweave.mining import Track
from scenweave.mining.detect import detect
from scenweave.mining.motion import positions_speed
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import DT, braking, car, recording, steady

LIMITS = load_thresholds()
LANE_CHANGES = {"LCF", "LCB", "CINF", "CINB", "COUTF", "COUTB"}


def codes(*tracks: Track, junctions: frozenset[str] = frozenset()) -> dict[str, list]:
    rec = recording(*tracks)
    rec.junction_lanes = junctions
    found: dict[str, list] = {}
    for event in detect(rec, LIMITS):
        found.setdefault(event.code, []).append(event)
    return found


def profile(*points: tuple[float, float]) -> Callable[[np.ndarray], np.ndarray]:
    times, speeds = zip(*points, strict=True)
    return lambda t: np.interp(t, times, speeds)


def neighbours() -> list[Track]:
    """Cars on lanes 1 to 3 ahead and behind, so lanes and their centres are known."""
    return [car(f"n{lane}{k}", 10, s0, steady(20), lane)
            for lane in (1, 2, 3) for k, s0 in enumerate((150.0, -60.0))]


def moving_across(lateral: Callable[[np.ndarray], np.ndarray],
                  label: Callable[[np.ndarray], np.ndarray]) -> Track:
    """A car on lane 2 whose lateral position (m from lane 2's centre, + right) and lane
    label follow the given functions of time."""
    base = car("changer", 10, 40, steady(20), 2)
    index = label(base.t).astype(float)
    return replace(base, y=-3.5 * 2 - lateral(base.t), lane_index=index,
                   lane=np.array([str(int(k)) for k in index], dtype=object))


def test_a_label_flip_without_crossing_the_line_is_no_lane_change():
    flip = moving_across(lambda t: 0.6 * np.clip((t - 3) / 2, 0, 1),
                         lambda t: np.where(t < 4.5, 2, 3))
    assert not LANE_CHANGES & set(codes(flip, *neighbours()))


def test_a_crossing_of_the_line_is_a_lane_change():
    crossing = moving_across(lambda t: 3.5 * np.clip((t - 3) / 3, 0, 1),
                             lambda t: np.where(t < 4.5, 2, 3))
    found = codes(crossing, *neighbours())
    assert [e.ego for e in found.get("LCF", []) + found.get("LCB", [])] == ["changer"]


def sag_and_snap(t: np.ndarray) -> np.ndarray:
    """A tracker's drift and snap: 18.0 -> 12.8 m/s over a second, then 23.7 within 0.3 s
    and back to 18 (the US-101 lead of issue 32)."""
    return np.interp(t, [0, 4.0, 5.0, 5.3, 5.8, 10], [18, 18, 12.8, 23.7, 18, 18])


def test_a_sag_and_snap_is_tracking_noise_and_no_brake():
    lead = car("lead", 10, 60, sag_and_snap, 2)
    noise = positions_speed(lead.t, lead.s, lead.speed).noise
    assert noise[(lead.t >= 4.2) & (lead.t <= 5.3)].all()  # the sag is named, not just the snap
    assert not noise[lead.t <= 3.0].any() and not noise[lead.t >= 7.0].any()
    found = codes(lead, car("ego", 10, 30, steady(18), 2))
    assert "BRAKE" not in found and "BR_BK" not in found


def test_a_real_brake_of_the_same_depth_is_kept():
    lead = car("lead", 10, 60, profile((0, 18), (4, 18), (5, 12.8), (10, 12.8)), 2)
    found = codes(lead, car("ego", 10, 30, steady(18), 2))
    assert [(e.ego, e.npc) for e in found["BRAKE"]] == [("ego", "lead")]


def test_a_spike_inside_a_brake_does_not_split_it():
    def spiked(t: np.ndarray) -> np.ndarray:
        speed = braking(20, 2.0, 3.0, 8.0)(t)  # the box jumps 2.7 m ahead and back:
        return speed + np.where((t >= 3.4) & (t < 3.7), 9.0, 0.0) \
            - np.where((t >= 3.7) & (t < 4.0), 9.0, 0.0)

    lead = car("lead", 10, 60, spiked, 2)
    found = codes(lead, car("ego", 10, 30, steady(20), 2))
    brakes = found.get("BRAKE", []) + found.get("BR_BK", [])
    assert len(brakes) == 1
    assert brakes[0].start_s <= 2.5 and brakes[0].end_s >= 5.0  # both halves, one event


def test_an_ego_standing_all_along_has_no_braking_lead():
    lead = car("lead", 10, 20, braking(8, 2, 3, 1), 2)
    assert "BR_BK" in codes(lead, car("ego", 10, 5, steady(2.0), 2))
    assert "BR_BK" not in codes(lead, car("ego", 10, 5, steady(0.0), 2))


def test_in_town_a_car_ahead_in_a_junction_lanelet_ends_the_free_ride():
    ego = car("ego", 10, 0, steady(10), 2)
    inside = replace(car("inside", 10, 30, steady(10), 2),
                     lane=np.full(int(round(10 / DT)) + 1, "J", dtype=object))
    beside = car("beside", 10, 30, steady(10), 3)
    town = frozenset({"J"})
    assert "FRF" in codes(ego, beside, junctions=town)
    assert "FRF" not in codes(ego, beside, inside, junctions=town)

"""Issue 32: what the detectors must not take for an event, on recordings made from physics.

A lane label that flips without the car crossing the line is no lane change; a tracker's
sag-and-snap of a speed is no brake, and a spike inside a real brake does not split it; an
ego standing all along has no braking lead; in town a car ahead on the ego's path, inside a
junction's lanelet, still ends a free ride, and a car standing in a left-turn lane reads its
own arrow.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
from lxml import etree

from scenweave.mining import Track
from scenweave.mining.detect import detect
from scenweave.mining.motion import positions_speed
from scenweave.mining.readers import read_file
from scenweave.mining.scene import Scene
from scenweave.mining.thresholds import load_thresholds
from scenweave.mining.tracks import LightPhase, TrafficLight
from tests.mining import make_fixtures as fixtures
from tests.mining.synthetic import DT, braking, car, events_by_code, profile, recording, steady

LIMITS = load_thresholds()
LANE_CHANGES = {"LCF", "LCB", "CINF", "CINB", "COUTF", "COUTB"}


def codes(*tracks: Track, junctions: frozenset[str] = frozenset()) -> dict[str, list]:
    rec = recording(*tracks)
    rec.junction_lanes = junctions
    return events_by_code(rec)


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


# -- U4_1: the light of the car's own lane and movement ---------------------------------------

def _town_car(track_id: str, x: np.ndarray, y: np.ndarray, lane: np.ndarray) -> Track:
    t = np.round(np.arange(len(x)) * DT, 3)
    step = np.hypot(np.diff(x), np.diff(y))
    heading = np.unwrap(np.arctan2(np.gradient(y), np.gradient(x)))
    s = np.concatenate([[0.0], np.cumsum(step)])
    return Track(id=track_id, length_m=4.5, width_m=1.8, vehicle_type="car", t=t, x=x, y=y,
                 heading=heading, speed=np.gradient(s, t), s=s, lane=lane.astype(object))


def _turning_left(track_id: str, x0: float) -> Track:
    """Along the left-turn lane (y = 1.75) at 8 m/s, turning left (radius 12 m) past x = 100."""
    d = x0 + 8.0 * np.arange(0.0, 12.0 + DT / 2, DT) - 100.0  # path past x = 100
    angle = np.clip(d, 0, None) / 12.0
    x = np.where(d < 0, 100 + d, 100 + 12 * np.sin(np.minimum(angle, np.pi / 2)))
    y = 1.75 + np.where(d < 0, 0, 12 - 12 * np.cos(np.minimum(angle, np.pi / 2))
                        + np.clip(d - 12 * np.pi / 2, 0, None))
    return _town_car(track_id, x, y, np.where(d < 0, "L", "J"))


def _waiting_in_the_turn_lane() -> Track:
    """Arrives at 8 m/s, brakes from 2 s and stands from 6 s with its front 2 m before the
    stop line at x = 100, to the end (its own path never shows where it goes)."""
    t = np.arange(0.0, 12.0 + DT / 2, DT)
    v = np.clip(np.where(t < 2, 8.0, 8.0 - 2.0 * (t - 2)), 0, None)
    x = 63.75 + np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2 * DT)])
    return _town_car("waiter", x, np.full(len(t), 1.75), np.full(len(t), "L"))


def _arrows(*tracks: Track) -> list:
    lines = (("L", 100.0, 3.5, 100.0, 0.0), ("S", 100.0, 0.0, 100.0, -3.5))
    red, green = (LightPhase(0.0, 30.0, "red"),), (LightPhase(0.0, 30.0, "green"),)
    lights = [TrafficLight("arrow", ("L",), None, red, "left", lines[:1]),
              TrafficLight("main", ("L", "S"), None, green, "straightRight", lines)]
    rec = recording(*tracks)
    rec.lights.extend(lights)
    rec.junction_lanes = frozenset({"J"})
    return [(e.code, e.ego, e.refused) for e in detect(rec, LIMITS) if e.code == "U4_1"]


def test_a_car_standing_in_a_left_turn_lane_reads_its_own_red_arrow():
    """The straight light is green, the lane's own left arrow red: a car standing at the
    line of a lane every recorded car turned left from stops for its arrow (U4_1); with no
    car showing where the lane goes, the lane's light for straight on (green) says nothing."""
    turners = (_turning_left("first", 75.0), _turning_left("second", 85.0))
    assert _arrows(_waiting_in_the_turn_lane(), *turners) == [("U4_1", "waiter", None)]
    assert _arrows(_waiting_in_the_turn_lane()) == []


# -- the line from the file's lane map ----------------------------------------------------------

def _two_lanes(path: Path, cars: dict[int, tuple[float, Callable[[int], float]]]) -> Path:
    """A CommonRoad file of two straight lanelets driving towards -x (100: y -3.5..0, the
    left lane; 101: y 0..3.5) and cars at 5 m/s for 6 s from ``x0``, at ``y(step)``."""
    root = etree.Element("commonRoad", commonRoadVersion="2020a",
                         benchmarkID="ZAM_Lines-1_1_T-1", timeStepSize=str(fixtures.DT),
                         author="ScenWeave tests", affiliation="ScenWeave", source="synthetic",
                         date="2026-01-01")
    fixtures._lanelet(root, 100, -3.5, 0.0, None, 101)
    fixtures._lanelet(root, 101, 0.0, 3.5, 100, None)
    for lanelet in root.iter("lanelet"):  # no light here: a highway's two lanes
        lanelet.remove(lanelet.find("trafficLightRef"))
    for number, (x0, y_of) in cars.items():
        fixtures._obstacle(root, number, "car", 4.5, 1.8, x0, 5.0, y_of)
    etree.ElementTree(root).write(str(path), pretty_print=True, xml_declaration=True,
                                  encoding="UTF-8")
    return path


def test_the_line_is_the_lanelets_border_in_a_file_with_a_lane_map(tmp_path, monkeypatch):
    monkeypatch.setattr(fixtures, "STEPS", 60)
    path = _two_lanes(tmp_path / "lines.xml", {
        1: (95.0, lambda k: 1.75 - 3.5 * min(1.0, max(0.0, (k - 15) / 20))),  # right to left
        # 1.5 m across, its label flips, but its centre stops 0.3 m past the line
        2: (40.0, lambda k: 1.2 - 1.5 * min(1.0, max(0.0, (k - 20) / 10))),
    })
    recording = read_file(path)
    assert Scene(recording, LIMITS).strips.keys() == {"100", "101"}
    flipped = next(t for t in recording.tracks if t.id == "2")
    assert len(set(flipped.lane)) == 2  # the label does flip
    changes = {e.ego for e in detect(recording, LIMITS) if e.code in LANE_CHANGES}
    assert changes == {"1"}

"""Issue 31 in mining: the speed a record gives is its positions' (0.5 s moving average), the
tracker's impossible jumps are named tracking noise, and a lane change is measured from the
lateral position: when the car crosses the line, and where it is when a track starts
mid-change."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from scenweave.mining import Track
from scenweave.mining.detect import detect
from scenweave.mining.motion import POSITIONS_AVERAGE_S, positions_speed
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import DT, car, profile, recording, steady

LIMITS = load_thresholds()
LANE_M = 3.5


def test_a_box_that_jumps_ahead_and_back_is_tracking_noise_not_speed():
    track = car("a", 10, 0, steady(20.0), 2)
    s = track.s.copy()
    s[50:53] += 1.5  # the tracker's box jumps 1.5 m ahead for 0.3 s: 15 m/s in 0.1 s, back
    measured = positions_speed(track.t, s, track.speed)
    assert measured.noise[50:53].all()
    assert not measured.noise[:40].any() and not measured.noise[63:].any()
    clean = measured.fitted[np.isfinite(measured.fitted)]
    assert np.abs(clean - 20.0).max() < 1e-6  # what is left is what the car drove
    assert np.isnan(measured.fitted[50:53]).all()


def hardest_second(speed: np.ndarray) -> float:
    return max(speed[k] - speed[k:k + 11].min() for k in range(len(speed)))


def test_a_hard_brake_is_no_noise_and_keeps_its_hardest_second():
    # 25 -> 17 m/s at 4 m/s^2 over 2 s: all of its hardest second is kept
    track = car("a", 10, 0, profile((0, 25), (4, 25), (6, 17), (10, 17)), 2)
    measured = positions_speed(track.t, track.s, track.speed)
    assert not measured.noise.any()
    assert hardest_second(measured.speed) == pytest.approx(4.0, abs=0.05)
    # 8 m/s^2 for exactly 1 s, sharp corners: a 0.5 s average rounds them, keeping 80 %
    track = car("b", 10, 0, profile((0, 25), (4, 25), (5, 17), (10, 17)), 2)
    measured = positions_speed(track.t, track.s, track.speed)
    assert not measured.noise.any()
    assert hardest_second(measured.speed) >= 0.8 * 8.0
    assert POSITIONS_AVERAGE_S <= 0.5


def test_a_brake_record_gives_the_positions_speed_and_names_its_noise():
    lead = car("lead", 12, 40, profile((0, 15), (4, 15), (6, 8), (12, 8)), 2)
    s = lead.s.copy()
    s[30:32] -= 1.2  # a tracking spike just before the brake
    lead = Track(**{**lead.__dict__, "s": s, "x": s})
    events = [e for e in detect(recording(lead, car("ego", 12, 20, steady(12), 2)), LIMITS)
              if e.code == "BR_BK"]
    (brake,) = events
    series = brake.series
    assert {"npc_speed_raw_ms", "npc_noise", "smoothing"} <= set(series)
    assert "0.5 s" in series["smoothing"]["speed_raw_ms"]
    raw, fitted = series["npc_speed_raw_ms"], series["npc_speed_ms"]
    assert all((f is None) == bool(n) for f, n in zip(fitted, series["npc_noise"], strict=True))
    assert all(f == r for f, r in zip(fitted, raw, strict=True) if f is not None)
    # 3.5 m/s lost within the best second: the intensity is the record's, not a smoothed one
    assert brake.fields["brake_intensity"] == pytest.approx(3.5 / 8, abs=0.02)


def changer(duration_s: float, lateral: Callable, lane: Callable) -> Track:
    """A car at 20 m/s whose lateral position (y, + left; lane n centred at -3.5 n) and lane
    label follow the given functions of time."""
    base = car("changer", duration_s, 30, steady(20.0), 2)
    lanes = lane(base.t).astype(float)
    return Track(**{**base.__dict__, "y": lateral(base.t), "lane_index": lanes,
                    "lane": np.array([str(int(k)) for k in lanes], dtype=object)})


def neighbours(duration_s: float) -> list[Track]:
    """Cars in lanes 1 and 2 (their positions fit the lanes' spacing), one right behind
    where the changer ends."""
    return [car("ahead", duration_s, 90, steady(20.0), 1),
            car("behind", duration_s, 12, steady(20.0), 1),
            car("other", duration_s, 0, steady(20.0), 2)]


def test_an_early_crossing_is_measured_where_the_car_crossed():
    # 1 s to the line (fast), then 3 s settling: a linear change would cross 2 s in
    lateral = profile((0, -7.0), (3, -7.0), (4, -5.25), (7, -3.5), (12, -3.5))
    label = lambda t: np.where(t < 4.0, 2, 1)  # noqa: E731
    found = detect(recording(changer(12, lateral, label), *neighbours(12)), LIMITS)
    (event,) = [e for e in found if e.code in ("LCF", "LCB")]
    fields = event.fields
    assert fields["lane_change_cross_s"] + event.start_s == pytest.approx(4.0, abs=0.1)
    assert fields["lane_change_width_m"] == pytest.approx(LANE_M, abs=0.05)
    assert abs(fields["lane_change_offset_m"]) < 0.2  # it starts on its lane's centre


def test_a_track_that_starts_mid_change_starts_where_it_was():
    # the track begins 1.2 m toward the new lane and crosses 0.5 s later
    lateral = profile((0, -7.0 + 1.2), (0.5, -5.25), (2.0, -3.5), (10, -3.5))
    label = lambda t: np.where(t < 0.5, 2, 1)  # noqa: E731
    found = detect(recording(changer(10, lateral, label), *neighbours(10)), LIMITS)
    (event,) = [e for e in found if e.code in ("LCF", "LCB")]
    assert event.start_s == pytest.approx(0.0, abs=DT)
    assert event.fields["lane_change_offset_m"] == pytest.approx(1.2, abs=0.1)
    assert event.fields["lane_change_cross_s"] == pytest.approx(0.5, abs=0.1)

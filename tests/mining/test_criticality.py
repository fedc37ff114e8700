"""How critical a mined event is (issue 32 item 5): numbers measured on a record's series,
checked against series made from physics whose answer is known, and on mined records."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from scenweave.mining.criticality import CRITICALITY_FIELDS, criticality
from scenweave.mining.mine import mine_recordings
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import braking, car, recording, steady

DT = 0.1


def pair_series(ego_v: float, npc_v: float, gap0: float, seconds: float = 3.0,
                npc_lane: float = 2.0) -> dict:
    """The ego in lane 2 and an NPC ``gap0`` ahead (negative: behind), both at constant
    speeds: the gap changes by their difference."""
    t = np.round(np.arange(0.0, seconds + DT / 2, DT), 3)
    gap = gap0 + (npc_v - ego_v) * t
    n = len(t)
    return {"t": t.tolist(), "ego_speed_raw_ms": [ego_v] * n, "npc_speed_raw_ms": [npc_v] * n,
            "npc_gap_m": gap.tolist(), "ego_lane": [2.0] * n, "npc_lane": [npc_lane] * n,
            "ego_lateral_m": [0.0] * n, "npc_lateral_m": [0.0] * n}


def test_a_follower_closing_in_has_its_least_time_to_collision_and_headway():
    numbers = criticality(pair_series(ego_v=20.0, npc_v=10.0, gap0=50.0))
    # the gap closes at 10 m/s from 50 m to 20 m at 3 s: 20 m / 10 m/s and 20 m / 20 m/s
    assert numbers["ttc_min_s"] == pytest.approx(2.0, abs=0.01)
    assert numbers["thw_min_s"] == pytest.approx(1.0, abs=0.01)
    assert numbers["brake_1s_max_ms2"] == 0.0 and numbers["lat_acc_peak_ms2"] == 0.0


def test_a_follower_behind_the_ego_counts_with_its_own_speed():
    numbers = criticality(pair_series(ego_v=10.0, npc_v=15.0, gap0=-30.0))
    # the NPC behind closes at 5 m/s: 15 m left at 3 s; its headway 15 m / 15 m/s
    assert numbers["ttc_min_s"] == pytest.approx(3.0, abs=0.01)
    assert numbers["thw_min_s"] == pytest.approx(1.0, abs=0.01)


def test_a_lead_pulling_away_has_no_time_to_collision_written_as_null():
    numbers = criticality(pair_series(ego_v=10.0, npc_v=12.0, gap0=20.0))
    assert numbers["ttc_min_s"] is None
    assert numbers["thw_min_s"] == pytest.approx(2.0, abs=0.01)
    assert "null" in json.dumps(numbers, allow_nan=False)


def test_a_car_of_another_lane_is_no_follower_or_lead():
    numbers = criticality(pair_series(ego_v=20.0, npc_v=10.0, gap0=50.0, npc_lane=3.0))
    assert numbers["ttc_min_s"] is None and numbers["thw_min_s"] is None


def test_tracking_noise_closes_in_on_nobody_and_brakes_nobody():
    series = pair_series(ego_v=15.0, npc_v=15.0, gap0=10.0)
    spike = [5.0 if 10 <= k < 14 else 15.0 for k in range(len(series["t"]))]
    series["npc_speed_raw_ms"] = spike
    series["npc_noise"] = [1.0 if 8 <= k < 16 else 0.0 for k in range(len(spike))]
    numbers = criticality(series)
    assert numbers["ttc_min_s"] is None and numbers["brake_1s_max_ms2"] == 0.0
    del series["npc_noise"]  # the same spike not marked as noise is a hard brake
    unmarked = criticality(series)
    # ... and the ego 10 m behind closes in at 10 m/s
    assert unmarked["ttc_min_s"] == pytest.approx(1.0, abs=0.01)
    assert unmarked["brake_1s_max_ms2"] == pytest.approx(10.0, abs=0.01)


def test_the_hardest_second_of_braking_is_its_mean_deceleration():
    t = np.round(np.arange(0.0, 4.0 + DT / 2, DT), 3)
    speed = np.clip(20.0 - 5.0 * np.clip(t - 1.0, 0, None), 12.0, None)  # 5 m/s^2 for 1.6 s
    series = {"t": t.tolist(), "ego_speed_raw_ms": speed.tolist()}
    assert criticality(series)["brake_1s_max_ms2"] == pytest.approx(5.0, abs=0.01)
    short = {"t": t[:8].tolist(), "ego_speed_raw_ms": speed[:8].tolist()}
    assert criticality(short)["brake_1s_max_ms2"] is None


def test_the_lateral_peak_of_a_lane_change():
    """A 3.5 m lane change over 4 s whose lateral acceleration is one sine period (smooth at
    both ends): its peak is 3.5 * 2 pi / 4^2."""
    t = np.round(np.arange(0.0, 6.0 + DT / 2, DT), 3)
    moving = np.clip(t - 1.0, 0.0, 4.0)
    lateral = 3.5 * (moving / 4 - np.sin(2 * math.pi * moving / 4) / (2 * math.pi))
    series = {"t": t.tolist(), "ego_lateral_m": lateral.tolist()}
    expected = 3.5 * 2 * math.pi / 16
    assert criticality(series)["lat_acc_peak_ms2"] == pytest.approx(expected, rel=0.06)


def test_a_series_without_numbers_has_every_field_null():
    numbers = criticality({"t": [0.0, 0.1]})
    assert list(numbers) == list(CRITICALITY_FIELDS)
    assert all(value is None for value in numbers.values())


def test_a_mined_braking_record_carries_its_criticality(tmp_path):
    """A lead braking at 3 m/s^2 in front of a follower: the record and the report say so."""
    scene = recording(car("lead", 12, 40, braking(20, 3, 3, 11), 2),
                      car("ego", 12, 10, steady(20), 2))
    report = mine_recordings([scene], tmp_path, load_thresholds())
    records = json.loads((tmp_path / "highway" / "BRAKE.json").read_text())
    numbers = records[0]["criticality"]
    assert numbers["brake_1s_max_ms2"] == pytest.approx(3.0, abs=0.3)
    assert numbers["ttc_min_s"] is not None and numbers["ttc_min_s"] > 0
    assert numbers["thw_min_s"] == pytest.approx(min(
        g / 20.0 for g in records[0]["series"]["npc_gap_m"] if g is not None), abs=0.02)
    written = json.loads((tmp_path / "mining_report.json").read_text())
    listed = [c for c in written["criticality"] if c["scenario_id"] == records[0]["scenario_id"]]
    assert listed and listed[0]["brake_1s_max_ms2"] == numbers["brake_1s_max_ms2"]
    assert report.values["BRAKE"]["brake_1s_max_ms2"]

"""Fitting speed phases to what a record says (``ingest.phases``, issue 22)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenweave.ingest import IngestReport, extract_params, iter_raw_records
from scenweave.ingest.phases import (
    DISTANCE_TOL_M,
    SPEED_TOL_MS,
    NoProfile,
    fit_end_values,
    fit_series,
)
from scenweave.ingest.samples import write_highway_samples
from scenweave.scenario_lib.phases import PhasedProfile, parse_phases

START_S = 2.0


def _lead(t: float) -> float:
    """The issue's lead: 12.0 -> 13.3 -> 12.2 -> 13.7 m/s."""
    corners = [(0.0, 12.0), (2.0, 13.3), (4.0, 12.2), (6.0, 13.7), (8.0, 13.7)]
    for (a, va), (b, vb) in zip(corners, corners[1:], strict=False):
        if t <= b:
            return va + (vb - va) * (t - a) / (b - a)
    return corners[-1][1]


def _series(noise: float = 0.0) -> tuple[list[float], list[float]]:
    rng = np.random.default_rng(3)
    times = [round(k * 0.1, 3) for k in range(81)]
    return times, [round(_lead(t) + float(rng.normal(0, noise)), 3) for t in times]


def _worst(times, speeds, phases) -> tuple[float, float]:
    profile = PhasedProfile(speeds[0], phases)
    driven, worst_v, worst_d = 0.0, 0.0, 0.0
    for k, (t, v) in enumerate(zip(times, speeds, strict=True)):
        if k:
            driven += (v + speeds[k - 1]) / 2 * (t - times[k - 1])
        worst_v = max(worst_v, abs(profile.speed(START_S + t) - v))
        fitted = profile.distance(START_S + t) - profile.distance(START_S + times[0])
        worst_d = max(worst_d, abs(fitted - driven))
    return worst_v, worst_d


@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_a_speed_curve_is_fitted_within_the_tolerances_at_every_sample(noise):
    times, speeds = _series(noise)
    phases = fit_series(times, speeds, START_S, speeds[0])
    worst_v, worst_d = _worst(times, speeds, phases)
    assert worst_v <= SPEED_TOL_MS + 1e-6 and worst_d <= DISTANCE_TOL_M + 1e-6
    assert 3 <= len(phases) <= 4  # three ramps (and the hold at the end is no phase)
    assert phases[0].start_s == START_S


def test_dropping_any_fitted_phase_leaves_the_tolerance():
    times, speeds = _series()
    phases = fit_series(times, speeds, START_S, speeds[0])
    for i in range(len(phases)):
        fewer = phases[:i] + phases[i + 1:]
        worst_v, worst_d = _worst(times, speeds, fewer)
        assert worst_v > SPEED_TOL_MS or worst_d > DISTANCE_TOL_M, i


def test_one_ramp_is_fitted_to_a_ramp():
    times = [round(k * 0.1, 3) for k in range(41)]
    speeds = [20.0 - 1.5 * t for t in times]
    [phase] = fit_series(times, speeds, START_S, 20.0)
    assert (phase.start_s, phase.duration_s, phase.target_ms) == (2.0, 4.0, 14.0)


def test_begin_end_values_get_one_ramp_when_it_meets_the_distance():
    assert len(fit_end_values(20.0, 16.0, START_S, 5.0, 90.4)) == 1


@pytest.mark.parametrize("distance", [60.0, 120.0, 30.0])
def test_begin_end_values_get_the_smallest_profile_meeting_the_distance(distance):
    v0, duration = (20.0, 5.0) if distance != 30.0 else (12.0, 8.0)  # 30 m: stop and go
    phases = fit_end_values(v0, v0, START_S, duration, distance)
    profile = PhasedProfile(v0, phases)
    assert profile.end_speed == v0
    end = phases[-1].end_s
    assert profile.distance(end) - profile.distance(START_S) == pytest.approx(distance, abs=0.1)
    assert len(phases) == 2
    assert profile.max_acceleration_ms2() <= 10.0


@pytest.mark.parametrize("distance, says", [(-5.0, "backwards"), (180.0, r"12.8 m/s\^2")])
def test_begin_end_values_no_profile_can_show_say_why(distance, says):
    with pytest.raises(NoProfile, match=says):
        fit_end_values(20.0, 20.0, START_S, 5.0, distance)


def test_phased_sample_rows_follow_the_unchanged_ones(tmp_path):
    write_highway_samples(tmp_path / "plain", 7, 3)
    write_highway_samples(tmp_path / "phased", 7, 3, phased=2)
    plain = {p.name: np.load(p, allow_pickle=True) for p in (tmp_path / "plain").glob("*.npy")}
    for path in (tmp_path / "phased").glob("*.npy"):
        table = np.load(path, allow_pickle=True)
        extra = 2 if path.name.startswith("FL") else 0
        assert len(table) == 3 + extra
        assert (table[:3] == plain[path.name]).all()  # the golden test's rows stay
    report = IngestReport()
    params = [extract_params(item.record) for item in iter_raw_records(tmp_path / "phased",
                                                                        report)]
    assert report.issues == []
    phased = [p for p in params if p.get("npc_phases")]
    assert {p["maneuver_class"] for p in phased} == {"FLF", "FLB"}
    assert len(phased) == 4 and all(len(p["npc_phases"]) >= 2 for p in phased)
    for p in phased:  # the profile lands on the recorded end gap
        npc = PhasedProfile(p["npc_speed_ms"], parse_phases(p["npc_phases"]))
        end = p["maneuver_start_s"] + p["duration_s"]
        ego_m = (p["ego_speed_ms"] + p["ego_end_speed_ms"]) / 2 * p["duration_s"]
        gained = npc.distance(end) - npc.distance(p["maneuver_start_s"]) - ego_m
        assert p["npc_distance_m"] + gained == pytest.approx(p["npc_distance_end_m"], abs=1.0)
        json.dumps(p)  # params stay JSON

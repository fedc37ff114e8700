"""Issue 36, item 3: slow town traffic's speed phases stay within the replay's series
tolerance once a player shows them.

A player starts each phase on its first step past the phase's time (esmini: 0.05 s late), so
a played ramp is behind by its slope times a step. A car pulling away from a queue at 10 m/s^2
loses 0.5 m/s to that alone; a fit within 0.3 m/s of the record then played 0.74 m/s off
(Peachtree 2 U1_1 row 6, at the edge of the judge's 0.75). The series below has that shape.
"""

from __future__ import annotations

import math

import pytest

from scenweave.ingest.phases import (
    PLAYED_SPEED_TOL_MS,
    PLAYER_STEP_S,
    SPEED_TOL_MS,
    fit_series,
)
from scenweave.judge.replay import SERIES_SPEED_TOL_MS
from scenweave.scenario_lib.phases import PhasedProfile

STEP_S = 0.1


def pulling_away(v0: float = 3.4, v1: float = 9.1, rate: float = 10.9) -> tuple[list, list]:
    """A car leaving a queue: ``v0`` to ``v1`` m/s along a smooth S of peak ``rate`` m/s^2,
    then cruising: 3 s sampled at 10 Hz."""
    rise = math.pi * (v1 - v0) / (2 * rate)  # the S's duration at that peak
    times = [round(k * STEP_S, 1) for k in range(31)]
    speeds = [v0 + (v1 - v0) * (1 - math.cos(math.pi * min(t / rise, 1.0))) / 2 for t in times]
    return times, speeds


def played(profile: PhasedProfile, time_s: float) -> float:
    """The fitted speed as a player shows it, a step late."""
    return profile.speed(max(time_s - PLAYER_STEP_S, 0.0))


def test_the_played_budget_is_inside_the_replays_tolerance():
    assert SPEED_TOL_MS <= PLAYED_SPEED_TOL_MS < SERIES_SPEED_TOL_MS


def test_a_car_pulling_away_from_a_queue_plays_within_the_tolerance():
    times, speeds = pulling_away()
    profile = PhasedProfile(speeds[0], fit_series(times, speeds, 0.0, speeds[0]))
    assert all(abs(profile.speed(t) - v) <= SPEED_TOL_MS + 1e-6
               for t, v in zip(times, speeds, strict=True))
    worst = max(abs(played(profile, t) - v) for t, v in zip(times[1:], speeds[1:], strict=True))
    assert worst <= PLAYED_SPEED_TOL_MS + 1e-6


@pytest.mark.parametrize("rate", [2.0, 6.0, 10.9])
def test_town_accelerations_keep_few_phases(rate):
    """The played budget costs phases only where the slope is steep: a gentle pull-away keeps
    its fit of before (at most three phases), a hard one at most two more."""
    times, speeds = pulling_away(rate=rate)
    phases = fit_series(times, speeds, 0.0, speeds[0])
    assert len(phases) <= (3 if rate < 5 else 5)

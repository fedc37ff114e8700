"""Issue 36: a car-following episode (FLF/FLB) is one car driving in another's lane behind it.

In town the lead is found on the path the follower drives next, which also holds a car the
follower is still beside, cutting in; and two boxes can overlap along the road for a while.
A follow episode starts only once the follower drives where the lead drove, with a bumper
gap, and never spans a clean sample where the gap is gone (Peachtree 2's 500 behind 512,
Lankershim 2-10's 2713 and 2731).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from scenweave.mining import Track
from scenweave.mining.detect import detect
from scenweave.mining.readers import read_file
from scenweave.mining.scene import ON_PATH_M
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import car, recording, steady

LIMITS = load_thresholds()
FOLLOWS = ("FLF", "FLB")
LANE_2_Y = -7.0


def _town_follows(*tracks: Track) -> list:
    rec = recording(*tracks)
    rec.junction_lanes = frozenset({"J"})  # a town: leads are read from the paths
    return [e for e in detect(rec, LIMITS) if e.code in FOLLOWS]


def _cutter(start_s: float, end_s: float) -> Track:
    """A car starting centre 4.5 m behind the lead, one lane to its right, moving into the
    lead's lane (2) between ``start_s`` and ``end_s`` at 3.5 m/s."""
    base = car("cutter", 12, 35.5, steady(3.5), 1)
    share = np.clip((base.t - start_s) / (end_s - start_s), 0.0, 1.0)
    lanes = np.where(share < 0.5, 1.0, 2.0)
    return replace(base, y=-3.5 - 3.5 * share, lane_index=lanes,
                   lane=np.array([str(int(k)) for k in lanes], dtype=object))


def test_a_car_cutting_in_is_followed_only_once_it_is_in_the_leads_lane():
    lead, cutter = car("lead", 12, 40, steady(4.0), 2), _cutter(0.0, 3.0)
    follows = _town_follows(lead, cutter)
    assert {(e.code, e.ego) for e in follows} == {("FLF", "cutter"), ("FLB", "lead")}
    first = min(e.start_s for e in follows)
    step = int(round(first / 0.1))
    assert abs(cutter.y[step] - LANE_2_Y) <= ON_PATH_M + 1e-9, (
        f"a follow starts at {first} s with the cutter {abs(cutter.y[step] - LANE_2_Y):.2f} m "
        "off the lead's lane")
    for event in follows:
        assert abs(event.series["npc_gap_m"][0]) > 0.0


def _closing_then_opening(t: np.ndarray) -> np.ndarray:
    """6 m/s, 7.5 m/s for a while (4.5 m gained), 4.5 m/s later (4.5 m given back)."""
    return np.interp(t, (0, 4, 5, 7, 8, 10, 11, 13, 14, 22),
                     (6, 6, 7.5, 7.5, 6, 6, 4.5, 4.5, 6, 6))


def test_no_follow_spans_a_stretch_where_the_bumpers_overlap():
    lead = car("lead", 22, 44.0, steady(6.0), 2)  # bumper gap 4.0 m at the start
    follower = car("follower", 22, 35.5, _closing_then_opening, 2)
    gap = lead.s - follower.s - 4.5
    overlap = lead.t[gap <= 0.0]
    assert overlap.min() < 9.0 < overlap.max()  # the fixture overlaps, -0.5 m at worst
    follows = _town_follows(lead, follower)
    assert {e.code for e in follows} == set(FOLLOWS)
    for event in follows:
        assert event.end_s < overlap.min() or event.start_s > overlap.max(), (
            f"{event.code} {event.start_s}-{event.end_s} s spans the overlap "
            f"{overlap.min():.1f}-{overlap.max():.1f} s")
    assert any(e.end_s < overlap.min() for e in follows)
    assert any(e.start_s > overlap.max() for e in follows)


# -- the shared town snippets ----------------------------------------------------------------

@cache
def _events(path: Path) -> tuple:
    return tuple(e for e in detect(read_file(path), LIMITS) if e.code in FOLLOWS)


def _follows_of(path: Path, pair: set[str]) -> list:
    return [e for e in _events(path) if {e.ego, e.npc} == pair]


def _clean_gaps(event) -> list[float]:
    series = event.series
    noisy = [bool(a) or bool(b) for a, b in zip(series["ego_noise"], series["npc_noise"],
                                                 strict=True)]
    return [g for g, n in zip(series["npc_gap_m"], noisy, strict=True)
            if g is not None and not n]


def test_peachtree_2_follow_of_500_starts_once_it_is_behind_512(ngsim_snippets):
    path = ngsim_snippets / "peachtree" / "USA_Peach-2_1_T-1.xml"
    follows = _follows_of(path, {"500", "512"})
    assert {(e.code, e.ego) for e in follows} == {("FLF", "500"), ("FLB", "512")}
    for event in follows:
        assert event.start_s >= 1.5, f"{event.code} starts at {event.start_s} s, side by side"
        assert event.refused is None and 0.0 not in _clean_gaps(event)


def test_lankershim_2_10_follow_of_2713_and_2731_ends_before_the_overlap(ngsim_snippets):
    path = ngsim_snippets / "lankershim" / "USA_Lanker-2_10_T-1.xml"
    for event in _follows_of(path, {"2713", "2731"}):
        assert event.end_s < 4.0 or event.start_s > 4.8, (event.code, event.start_s,
                                                          event.end_s)
        assert 0.0 not in _clean_gaps(event)


@pytest.mark.parametrize("ids", [{"2585", "2567"}, {"2725", "2733"}, {"2819", "2822"}])
def test_lankershim_2_10_follows_behind_in_lane_stay(ngsim_snippets, ids):
    """Labelled follows of cars one behind the other (benchmarks/mining_labels) are kept."""
    path = ngsim_snippets / "lankershim" / "USA_Lanker-2_10_T-1.xml"
    assert {e.code for e in _follows_of(path, ids)} == set(FOLLOWS)

"""The CommonRoad reader on the team's real NGSIM snippets (skipped where they are absent)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from scenweave.mining.readers import read_recordings


@pytest.fixture(scope="module")
def us101(ngsim_snippets):
    return list(read_recordings(ngsim_snippets / "us101"))


def test_the_four_us101_snippets_read(us101):
    assert [r.reader for r in us101] == ["commonroad"] * 4
    assert all(r.dt == pytest.approx(0.1) and r.warnings == [] for r in us101)
    counts = [len(r.tracks) for r in us101]
    assert all(2 <= n <= 80 for n in counts) and sum(counts) >= 80, counts
    for recording in us101:
        for track in recording.tracks:
            assert len(track.t) >= 2 and np.all(np.diff(track.t) > 0)
            assert track.vehicle_type == "car" and track.speed.min() >= 0


def test_s_grows_for_nearly_all_cars(us101):
    tracks = [t for r in us101 for t in r.tracks]
    # over 1 s, a queued car may creep back by a few cm of position noise, not more
    monotone = [np.all(t.s[10:] - t.s[:-10] > -0.1) for t in tracks]
    assert np.mean(monotone) >= 0.95


def test_every_position_is_on_a_lane_and_lanes_are_ordered(us101):
    for recording in us101:
        index = np.concatenate([t.lane_index for t in recording.tracks])
        assert not np.isnan(index).any() and set(index) <= {1.0, 2.0, 3.0, 4.0, 5.0, 6.0}
        lanes = np.concatenate([t.lane for t in recording.tracks])
        assert "" not in set(lanes)


def test_lane_changes_are_seen(us101):
    changers = [t for r in us101 for t in r.tracks if len(set(t.lane_index)) > 1]
    assert len(changers) >= 2


def test_lankershim_lights_have_phases_and_stop_lines(ngsim_snippets):
    recordings = list(read_recordings(ngsim_snippets / "lankershim"))
    assert len(recordings) >= 2  # the shared folder grows: every snippet it holds must pass
    for recording in recordings:
        lit = [light for light in recording.lights if light.phases]
        assert len(lit) >= 4
        for light in lit:
            assert light.lanes and light.stop_line_s is not None
            assert {p.state for p in light.phases} <= {"green", "yellow", "red"}
            assert light.phases[0].start_s == 0.0
        last = max(t.t[-1] for t in recording.tracks)
        for light in lit:  # the phases cover the snippet without gaps (no light is inactive)
            assert light.phases[-1].end_s == pytest.approx(last)
            assert all(a.end_s == b.start_s for a, b in itertools.pairwise(light.phases))
        lanes = {lane for t in recording.tracks for lane in t.lane}
        controlled = {lane for light in recording.lights for lane in light.lanes}
        assert lanes & controlled  # some car drives on a signalised approach

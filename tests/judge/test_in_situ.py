"""The in-situ judge on playbacks made by hand: shares and worst per vehicle, the hard limits,
speeds against the recorded positions' change, collisions the record lacks."""

from __future__ import annotations

import numpy as np
import pytest

from scenweave.judge.in_situ import RecordedPath, boxes_touch, judge_in_situ
from scenweave.player import Playback


def _path(name: str, x0: float, speed: float, y: float = 0.0, n: int = 21) -> RecordedPath:
    t = [round(0.1 * k, 3) for k in range(n)]
    return RecordedPath(name, t, [x0 + speed * s for s in t], [y] * n, [0.0] * n, 4.0, 1.8)


def _playback(*paths: RecordedPath, shift: dict[str, tuple[int, float]] | None = None,
              collisions: list[tuple[float, str, str]] | None = None) -> Playback:
    """What esmini would show for ``paths`` played exactly (``shift``: name -> (sample, dx))."""
    times = list(paths[0].t)
    playback = Playback(times=times, collisions=collisions or [])
    for path in paths:
        x = np.array(path.x, dtype=float)
        if shift and path.name in shift:
            k, dx = shift[path.name]
            x[k] += dx
        speed = np.concatenate([[0.0], np.diff(x) / 0.1])
        playback.tracks[path.name] = {"x": x.tolist(), "y": list(path.y),
                                      "h": list(path.heading), "speed": speed.tolist()}
    return playback


def test_a_replay_that_plays_the_record_passes():
    record = [_path("hero", 0.0, 10.0), _path("v1", 20.0, 8.0)]
    verdict = judge_in_situ(_playback(*record), record)
    assert verdict.passed and verdict.findings == []
    assert verdict.overall.samples == 42 and verdict.overall.position_share == 1.0
    assert verdict.vehicles["v1"].speed_share == 1.0


def test_one_sample_off_is_counted_and_named():
    record = [_path("hero", 0.0, 10.0), _path("v1", 20.0, 8.0)]
    verdict = judge_in_situ(_playback(*record, shift={"v1": (7, 0.3)}), record)
    fit = verdict.vehicles["v1"]
    assert fit.position_within == 20 and fit.worst_position_m == pytest.approx(0.3)
    assert fit.worst_position_at_s == pytest.approx(0.7)
    assert verdict.overall.worst_position_of == "v1"
    (finding,) = [f for f in verdict.findings if f.code == "IN_SITU_POSITION"]
    assert "v1 0.30 m at 0.70 s" in finding.message
    assert finding.severity == "error"  # 41 of 42 is under 99.5 %
    # the time is a field of the verdict the viewer reads, not only words in the message
    (written,) = [f for f in verdict.to_dict()["findings"] if f["code"] == "IN_SITU_POSITION"]
    assert written["t"] == pytest.approx(0.7)


def test_beyond_half_a_metre_is_an_error_even_when_rare():
    record = [_path(f"v{i}", 10.0 * i, 5.0, n=201) for i in range(3)]
    verdict = judge_in_situ(_playback(*record, shift={"v2": (50, 0.6)}), record)
    assert verdict.overall.position_share > 0.995
    assert "IN_SITU_POSITION" in [f.code for f in verdict.findings if f.severity == "error"]


def test_speed_is_judged_against_the_recorded_positions_change():
    record = [_path("hero", 0.0, 10.0)]
    playback = _playback(*record)
    playback.tracks["hero"]["speed"][10] += 0.5
    verdict = judge_in_situ(playback, record)
    fit = verdict.vehicles["hero"]
    assert fit.speed_samples == 20  # every step of the record
    assert fit.speed_within == 19 and fit.worst_speed_at_s == pytest.approx(1.0)
    assert [f.code for f in verdict.findings] == ["IN_SITU_SPEED"]


def test_standstill_noise_is_named_not_compared():
    x = [5.0, 5.0, 4.7, 5.0, 5.0, 5.0]
    record = [RecordedPath("v3", [0.1 * k for k in range(6)], x, [0.0] * 6, [0.0] * 6, 4, 2)]
    playback = Playback(times=list(record[0].t), tracks={"v3": {
        "x": [5.0] * 6, "y": [0.0] * 6, "h": [0.0] * 6, "speed": [0.0] * 6}})
    verdict = judge_in_situ(playback, record)
    fit = verdict.vehicles["v3"]
    # the scenario holds the first three samples between 5.0 and 4.7: three steps are noise
    assert fit.backward_samples == 3 and fit.held_samples == 3
    assert fit.position_within == 5  # the share counts the held samples against the record
    assert fit.worst_held_m == pytest.approx(0.3) and fit.worst_position_m == 0.0
    (held,) = [f for f in verdict.findings if f.code == "IN_SITU_HELD"]
    assert held.severity == "warning" and "0.30 m" in held.message
    # noise the scenario holds is named, not held against the replay: it passes
    assert fit.held_off == 1 and fit.followed_share == 1.0
    (position,) = [f for f in verdict.findings if f.code == "IN_SITU_POSITION"]
    assert position.severity == "warning" and verdict.passed
    assert fit.speed_samples == 2 and fit.speed_within == 2  # the two steps after the hold


def test_a_collision_the_record_lacks_is_an_error_and_one_it_shows_is_not():
    apart = [_path("hero", 0.0, 10.0), _path("v1", 20.0, 10.0)]
    touches = [(1.0, "hero", "v1"), (1.1, "hero", "v1"), (1.2, "hero", "v1"), (1.8, "hero", "v1")]
    verdict = judge_in_situ(_playback(*apart, collisions=touches), apart)
    assert [f.message for f in verdict.findings] == [
        "hero and v1 collide from 1.00 s to 1.20 s; the record shows them apart",
        "hero and v1 collide from 1.80 s to 1.80 s; the record shows them apart"]
    assert [f["t"] for f in verdict.to_dict()["findings"]] == [1.0, 1.8]
    touching = [_path("hero", 0.0, 10.0), _path("v1", 3.95, 10.0)]
    verdict = judge_in_situ(_playback(*touching, collisions=[(1.0, "hero", "v1")]), touching)
    assert verdict.passed and verdict.recorded_collisions == [(1.0, "hero", "v1")]


def test_the_external_hero_is_not_judged_and_a_missing_vehicle_is_named():
    record = [_path("hero", 0.0, 10.0), _path("v1", 20.0, 8.0)]
    playback = _playback(*record, shift={"hero": (5, 3.0)})
    del playback.tracks["v1"]
    verdict = judge_in_situ(playback, record, skip={"hero"})
    assert "hero" not in verdict.vehicles
    assert [f.code for f in verdict.findings] == ["IN_SITU_MISSING", "IN_SITU_EMPTY"]


def test_an_engine_error_is_the_one_finding():
    verdict = judge_in_situ(Playback(engine_error="aborted"), [_path("hero", 0.0, 1.0)])
    assert [f.code for f in verdict.findings] == ["IN_SITU_ENGINE"] and not verdict.passed


def test_boxes_touch_within_the_margin_only():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    assert boxes_touch(square, square + [0.5, 0.5])
    assert not boxes_touch(square, square + [1.2, 0.0])
    assert boxes_touch(square, square + [1.05, 0.0], margin_m=0.1)
    diamond = np.array([[2.0, 0.5], [2.6, 1.1], [2.0, 1.7], [1.4, 1.1]])
    assert not boxes_touch(square, diamond)  # apart along the diamond's own edge normal

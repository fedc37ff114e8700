"""Issue 31: a mined lane change plays when it happened, in the real esmini.

A cut-in whose cutter reaches the line 1 s into a 4 s lane change (a linear change of 4 s
crosses at 2 s), and one whose cutter was recorded mid-change (1.0 m toward the ego's lane,
crossing 0.6 s later), are extracted, spawned, written by the reference script and played:
the played crossing must be within 0.3 s of the recorded one, the played start within 0.3 m
of the recorded offset. A record that says another crossing time is a ``REPLAY_SERIES``
naming the crossing.
"""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from lxml import etree

from scenweave import corpus, roads
from scenweave.ingest import check_playable, extract_params
from scenweave.judge import validate_xosc
from scenweave.judge.replay import SERIES_CROSSING_TOL_S, SERIES_OFFSET_TOL_M, judge_replay
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.player import ReplaySettings, replay_file
from scenweave.spawn_db import SpawnMatcher

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("esmini")]

STEP_S = 0.1
DURATION_S = 4.0
SPEED_MS = 22.0
GAP_M = 20.0


def cut_in(cross_s: float, offset_m: float) -> dict:
    """A CINF record as mining writes it: the cutter 20 m ahead at the ego's speed, moving
    left into the ego's lane; it crosses the line ``cross_s`` after the event starts, from
    ``offset_m`` off its lane's centre toward the ego's lane."""
    times = [round(k * STEP_S, 3) for k in range(int(DURATION_S / STEP_S) + 1)]
    return {
        "schema_version": "phase1.v1", "scenario_id": "CINF_lateral_test_row000000",
        "maneuver_class": "CINF", "maneuver_tag": "cut_in_front", "domain": "highway",
        "has_npc": True, "npc_position": "front", "binning_version": "mined",
        "source": {"file": "synthetic", "row_index": 0},
        "params": {"ego_vel_kmh": SPEED_MS * 3.6, "cutter_vel_kmh": 0.0, "delta_vel_kmh": 0.0,
                   "duration_s": DURATION_S, "npc_distance_m": GAP_M,
                   "other_dir_traffic": "No", "direction": "Left", "lead_vehicle_type": "Car",
                   "lane_change_cross_s": cross_s, "lane_change_offset_m": offset_m,
                   "lane_change_width_m": 3.5},
        "conventions": {"gaps_between": "bumpers", "relative_speed_sign": 1,
                        "direction_is": "move"},
        "series": {"t": times, "ego_speed_ms": [SPEED_MS] * len(times),
                   "npc_speed_ms": [SPEED_MS] * len(times),
                   "npc_gap_m": [GAP_M] * len(times)},
    }


def made(tmp_path, record: dict) -> tuple[Path, dict]:
    params = extract_params(record)
    check_playable(params)
    placed = dict(SpawnMatcher().assign(params, 0))
    return corpus.generate(copy.deepcopy(placed), tmp_path / "cinf.xosc"), placed


def played(tmp_path, record: dict) -> tuple[dict, list]:
    """Everything the judge checks, the replay included: series errors and findings."""
    path, placed = made(tmp_path, record)
    result = validate_xosc(path, placed, replay=ReplaySettings())
    return result.playback.series_errors or {}, [f"{f.code}: {f.message}" for f in result.errors]


@pytest.mark.parametrize(("cross_s", "offset_m"), [(1.0, 0.0), (0.6, 1.0)])
def test_the_cutter_crosses_the_line_when_recorded(tmp_path, cross_s, offset_m):
    errors, failed = played(tmp_path, cut_in(cross_s, offset_m))
    assert not failed, failed
    assert errors["npc lane change crossing"]["max"] <= SERIES_CROSSING_TOL_S
    assert errors["npc lateral offset at start"]["max"] <= SERIES_OFFSET_TOL_M


def test_a_crossing_off_the_record_is_named(tmp_path):
    path, params = made(tmp_path, cut_in(1.0, 0.0))
    params["lane_change_cross_s"] += 1.0  # the record now crosses 1 s later
    playback = replay_file(path, roads.DEFAULT_MAP_PATH, ReplaySettings())
    found = judge_replay(playback, params, ScenarioDoc(etree.parse(str(path))))
    errors = playback.series_errors or {}
    assert errors["npc lane change crossing"]["max"] == pytest.approx(1.0, abs=0.15)
    assert any(f.code == "REPLAY_SERIES" and "lane change crossing" in f.message
               for f in found), found


def test_a_moove_row_keeps_one_linear_change_over_its_duration():
    record = cut_in(1.0, 0.0)
    for key in ("lane_change_cross_s", "lane_change_offset_m", "lane_change_width_m"):
        del record["params"][key]
    params = extract_params(record)
    assert "lane_change_cross_s" not in params and "npc_lane_offset_m" not in params

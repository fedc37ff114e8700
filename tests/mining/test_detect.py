"""Detection on recordings made from physics: each class is found where it happens, with the
MOOVE fields of its record, and nowhere else."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenweave.mining import Track
from scenweave.mining.detect import detect
from scenweave.mining.thresholds import DEFAULT_THRESHOLDS, ThresholdsError, load_thresholds
from tests.mining.synthetic import braking, car, recording, steady, switch

LIMITS = load_thresholds()


def found(*tracks: Track, limits=LIMITS) -> dict[str, list]:
    events: dict[str, list] = {}
    for event in detect(recording(*tracks), limits):
        events.setdefault(event.code, []).append(event)
    return events


def test_a_lead_braking_hard_in_front_of_a_follower_is_brake():
    events = found(car("lead", 12, 60, braking(25, 4, 5, 10), 2),
                   car("ego", 12, 30, steady(25), 2))
    (brake,) = events["BRAKE"]
    assert (brake.ego, brake.npc) == ("ego", "lead")
    f = brake.fields
    assert f["ego_vel_kmh"] == pytest.approx(90, abs=1)
    assert f["lead_vel_kmh"] == pytest.approx(90, abs=3)
    assert f["delta_vel_kmh"] == pytest.approx(-54, abs=6)
    # the phase spans the falling speed: the 3 s brake, blurred by at most the 1 s smoothing
    assert 3.0 - 0.1 <= f["duration_s"] <= 3.0 + 1.0
    assert f["npc_distance_m"] == pytest.approx(30 - 4.5, abs=1)  # bumpers: centres - 4.5 m
    assert f["brake_intensity"] == pytest.approx(5 / 8, abs=0.08)
    assert brake.series["npc_speed_ms"][0] == pytest.approx(25, abs=1)


def test_braking_in_stop_and_go_traffic_is_br_bk():
    events = found(car("lead", 10, 30, braking(10, 3, 4, 2), 2),
                   car("ego", 10, 15, steady(10), 2))
    assert [e.code for e in events.get("BR_BK", [])] == ["BR_BK"]
    assert "BRAKE" not in events


def test_a_braking_car_with_nobody_close_behind_is_no_brake_record():
    events = found(car("lead", 12, 160, braking(25, 4, 5, 10), 2),
                   car("ego", 12, 30, steady(25), 2))
    assert "BRAKE" not in events


def test_noisy_positions_do_not_look_like_hard_braking():
    rng = np.random.default_rng(1)
    noisy = car("lead", 20, 60, steady(20), 2)
    s = noisy.s + rng.normal(0, 0.08, len(noisy.s))
    jittery = Track(**{**noisy.__dict__, "s": s, "x": s,
                       "speed": np.gradient(s, noisy.t)})  # differentiated: +-10 m/s^2 swings
    assert np.abs(np.gradient(jittery.speed, noisy.t)).max() > 10
    events = found(jittery, car("ego", 20, 35, steady(20), 2))
    assert "BRAKE" not in events


def test_a_car_changing_into_the_ego_lane_ahead_of_it_is_a_cut_in_front():
    events = found(car("ego", 12, 0, steady(25), 2),
                   car("cutter", 12, 15, steady(26), switch(3, 2, 6)))
    (cin,) = events["CINF"]
    assert (cin.ego, cin.npc) == ("ego", "cutter")
    assert cin.fields["direction"] == "Left"  # lane 3 -> 2: towards the left
    assert cin.fields["npc_distance_m"] > 0
    assert cin.fields["cutter_vel_kmh"] == pytest.approx(3.6, abs=0.5)
    assert "CINB" not in events or all(e.ego != "ego" for e in events["CINB"])


def test_a_car_changing_in_behind_the_ego_is_a_cut_in_behind():
    events = found(car("ego", 12, 40, steady(25), 2),
                   car("cutter", 12, 20, steady(25), switch(1, 2, 6)))
    (cin,) = events["CINB"]
    assert cin.ego == "ego" and cin.fields["npc_distance_m"] < 0
    assert cin.fields["direction"] == "Right"


def test_the_lead_leaving_the_ego_lane_is_a_cut_out_front_and_the_follower_cut_out_behind():
    events = found(car("ego", 12, 30, steady(25), 2),
                   car("lead", 12, 55, steady(25), switch(2, 1, 6)),
                   car("back", 12, 5, steady(25), switch(2, 3, 6)))
    assert [(e.ego, e.npc) for e in events["COUTF"]] == [("ego", "lead")]
    assert [(e.ego, e.npc) for e in events["COUTB"]] == [("ego", "back")]


def test_the_ego_changing_lane_is_lcf_or_lcb_by_where_its_new_neighbour_is():
    ahead = found(car("ego", 12, 30, steady(25), switch(2, 1, 6)),
                  car("other", 12, 60, steady(25), 1))
    behind = found(car("ego", 12, 30, steady(25), switch(2, 1, 6)),
                   car("other", 12, 10, steady(25), 1))
    assert [e.ego for e in ahead["LCF"]] == ["ego"] and "LCB" not in ahead
    assert [e.ego for e in behind["LCB"]] == ["ego"]
    assert ahead["LCF"][0].fields["direction"] == "Left"


def test_following_at_a_steady_gap_is_flf_for_the_follower_and_flb_for_the_lead():
    events = found(car("lead", 8, 40, steady(20), 2), car("ego", 8, 15, steady(20), 2))
    (flf,) = events["FLF"]
    (flb,) = events["FLB"]
    assert (flf.ego, flf.npc) == ("ego", "lead") and (flb.ego, flb.npc) == ("lead", "ego")
    assert flf.fields["npc_distance_begin_m"] == pytest.approx(20.5, abs=0.5)
    assert flf.fields["behavior_type"] == "B3"
    assert flf.fields["duration_s"] == pytest.approx(8.0, abs=0.1)


def test_a_short_following_episode_is_not_one():
    events = found(car("lead", 3, 40, steady(20), 2), car("ego", 3, 15, steady(20), 2))
    assert "FLF" not in events


def test_thresholds_are_data(tmp_path):
    tracks = (car("lead", 12, 60, braking(25, 4, 1.5, 10), 2), car("ego", 12, 30, steady(25), 2))
    assert "BRAKE" not in found(*tracks)  # 1.5 m/s^2 is below the bundled 2.0
    mine = json.loads(DEFAULT_THRESHOLDS.read_text())
    mine["brake"]["deceleration_ms2"] = 1.0
    mine["brake"]["surprise"] = 1
    path = tmp_path / "t.json"
    path.write_text(json.dumps(mine))
    warnings: list[str] = []
    assert "BRAKE" in found(*tracks, limits=load_thresholds(path, warnings))
    assert warnings and "surprise" in warnings[0]


def test_a_thresholds_file_missing_a_number_is_one_clear_error(tmp_path):
    path = tmp_path / "t.json"
    path.write_text(json.dumps({"smoothing": {"window_s": 1.0}}))
    with pytest.raises(ThresholdsError, match="section 'neighbours' is missing"):
        load_thresholds(path)

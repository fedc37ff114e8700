"""Urban canonical records and params, with values worked out by hand (thesis Table 5.1)."""

from __future__ import annotations

import pytest

from scenweave.ingest import check_record, extract_params
from scenweave.ingest.urban import canonicalize_scene
from tests.ingest.builders import obstacle, scene

REGULAR = [100.0, 101.0, 102.0, 103.0, 104.0]
#: a car's pos_x is its bumper gap: the ego's front overhang (0.8 x 4.8 m) and the car's
#: rear one (0.2 x 3.7 m) make it the reference points' distance params hold
CAR_OVERHANGS_M = 0.8 * 4.8 + 0.2 * 3.7


def _params(data: dict) -> dict:
    record = canonicalize_scene(data, f"{data['scenario_code']}/x.json")
    check_record(record)
    return extract_params(record)


def test_stop_at_red_light():
    # v = 10, 10, 5, 0, 0 m/s; the light is at 30 m, the 5-m-before point (25 m) is never
    # reached, so yellow_delay = 25 m / 10 m/s = 2.5 s; first v <= 0.1 m/s at t = 3 s
    data = scene("U4_1", [36, 36, 18, 0, 0], REGULAR, [1000, 1010, 1017.5, 1020, 1020],
                 light=(30.0, 172))
    p = _params(data)
    assert p["maneuver_tag"] == "stop_at_tfl_red"
    assert p["ego_speed_ms"] == pytest.approx(10.0)
    assert p["ego_end_speed_ms"] == pytest.approx(0.0)
    assert p["brake_time_s"] == pytest.approx(3.0)
    assert p["yellow_delay_s"] == pytest.approx(2.5)
    assert p["drive_distance_m"] == pytest.approx(20.0)
    assert p["tfl_ds_m"] == pytest.approx(30.0)
    assert p["tfl_state"] == "red"
    assert p["duration_s"] == pytest.approx(4.0)
    assert p["timeout_s"] == pytest.approx(10.0)


def test_stop_at_orange_light_with_irregular_steps_clamps_the_yellow_delay_up():
    # 5-m point = 7 m, reached between t=0.5 (6.25 m) and t=1.5 (13.75 m): t = 0.6 s -> 1.0 s
    times = [0.0, 0.5, 1.5, 2.0, 3.0]
    data = scene("U4_1", [54, 36, 18, 3.6, 0], times, [0, 6.25, 13.75, 15.25, 15.75],
                 light=(12.0, 170))
    p = _params(data)
    assert p["yellow_delay_s"] == pytest.approx(1.0)
    assert p["brake_time_s"] == pytest.approx(3.0)
    assert p["tfl_state"] == "orange"
    record = canonicalize_scene(data, "U4_1/x.json")
    assert record["metadata"]["time_step"]["regular"] is False
    assert record["metadata"]["time_step"]["median_s"] == pytest.approx(0.75)


def test_pass_green_interpolates_the_time_to_the_light():
    # constant 10 m/s; 35 m is reached half-way between t=3 (30 m) and t=4 (40 m)
    data = scene("U4_2", [36] * 5, REGULAR, [0, 10, 20, 30, 40], light=(40.0, 167))
    p = _params(data)
    assert p["yellow_delay_s"] == pytest.approx(3.5)
    assert p["brake_time_s"] == pytest.approx(4.0)  # never stops: the whole span
    assert p["tfl_state"] == "green"
    assert canonicalize_scene(data, "U4_2/x.json")["metadata"]["time_step"]["regular"] is True


def test_far_light_clamps_yellow_delay_to_eight_seconds():
    data = scene("U4_2", [36] * 5, REGULAR, [0, 10, 20, 30, 40], light=(100.0, 170))
    assert _params(data)["yellow_delay_s"] == pytest.approx(8.0)  # 95 m / 10 m/s = 9.5 s


def test_light_right_ahead_clamps_yellow_delay_to_one_second():
    data = scene("U4_3", [36] * 5, REGULAR, [0, 10, 20, 30, 40], light=(3.0, 167))
    p = _params(data)
    assert p["yellow_delay_s"] == pytest.approx(1.0)
    assert p["turn"] == "straight"


def test_right_turn_class_says_right():
    data = scene("U4_4", [30, 25, 20, 20, 20], REGULAR, [0, 7.6, 13.8, 19.4, 25],
                 light=(20.0, 167))
    p = _params(data)
    assert p["turn"] == "right"
    assert p["maneuver_tag"] == "turn_right_at_tfl_green"


def test_in_lane_driving_roles_ttc_and_weather():
    v = 10.0
    frames = [[obstacle(7, 25.0 - i * 1.0, 9.0, v, ttc=[4.0, 2.5, -1.0, 3.0, 3.0][i]),
               obstacle(8, 80.0 - 22 * i, -12.0, v, rel_lane=1)] for i in range(5)]
    data = scene("U1_1", [36] * 5, REGULAR, [0, 10, 20, 30, 40], obstacles=frames,
                 precipitation=2, day_period=2)
    record = canonicalize_scene(data, "U1_1/x.json")
    roles = {a["id"]: a["role"] for a in record["initial_state"]["actors"]}
    assert roles == {7: "lead_vehicle", 8: "oncoming"}
    assert record["semantics"]["criticality_metric"]["min_ttc_s"] == pytest.approx(2.5)
    assert record["environment"]["weather_key"] == "Night_Rain"
    assert record["environment"]["precipitation"] == "Moderate Rain"
    lead_track = next(t for t in record["dynamic_content"]["actor_trajectories"] if t["id"] == 7)
    # the lead's own displacement: ego ds + pos_x, relative to its start (25 m)
    assert lead_track["ds"] == pytest.approx([0.0, 9.0, 18.0, 27.0, 36.0])
    p = extract_params(record)
    assert p["tfl_ds_m"] is None and p["yellow_delay_s"] is None and p["tfl_state"] is None
    assert p["lead_present"] is True
    # pos_x is the bumper gap; params hold the reference points' distance
    assert p["lead_distance_m"] == pytest.approx(25.0 + CAR_OVERHANGS_M)
    assert p["lead_speed_ms"] == pytest.approx(9.0)
    assert p["oncoming_present"] is True and p["pedestrian_present"] is False
    assert p["weather_key"] == "Night_Rain"
    assert p["min_ttc_s"] == pytest.approx(2.5)
    description = record["semantics"]["description"]
    assert description.count(".") >= 2 and "36 km/h" in description and "lead car" in description


def test_pedestrian_role_and_decoded_codes():
    frames = [[obstacle(9, 30.0, 0.0, 10.0, rel_lane=2, classification=4, pos_y=4.0)]] * 5
    data = scene("U4_3", [36] * 5, REGULAR, [0, 10, 20, 30, 40], light=(40.0, 167),
                 obstacles=frames)
    record = canonicalize_scene(data, "U4_3/x.json")
    actor = record["initial_state"]["actors"][0]
    assert (actor["role"], actor["classification"]) == ("pedestrian", "Pedestrian")
    assert record["infrastructure"]["traffic_signs"][0]["label"] == "Green Traffic Light"
    assert record["environment"]["road_type"] == "Urban Road"
    assert record["metadata"]["country"] == "France"
    assert record["scenario_id"] == "U4_3_20230512T143210_x"


def _assert_params(p: dict, expected: dict) -> None:
    for key, value in expected.items():
        if isinstance(value, float):
            assert p[key] == pytest.approx(value, abs=1e-9), key
        else:
            assert p[key] == value, key


ENVIRONMENT = dict(speed_limit_kmh=50, lane_count=2, lane_width_m=3.5, road_type="urban_road")
NOBODY = dict(lead_present=False, lead_distance_m=0.0, lead_speed_ms=0.0, lead_vehicle_type=None,
              has_npc=False, npc_position=None, oncoming_present=False, pedestrian_present=False,
              gap_ahead_m=0.0, gap_behind_m=0.0)


def test_in_lane_driving_slowing_in_rain_with_irregular_steps():
    # v = 54, 50.4, 46.8, 46.8 km/h = 15, 14, 13, 13 m/s at t = 0, 0.5, 1.5, 2.0 s after 10.0 s;
    # odometer 500 -> 527.25 m; no light, nobody around, light rain by day
    data = scene("U1_1", [54, 50.4, 46.8, 46.8], [10.0, 10.5, 11.5, 12.0],
                 [500, 507.25, 520.75, 527.25], precipitation=1, day_period=1)
    _assert_params(_params(data), dict(
        maneuver_tag="in_lane_driving", domain="urban", weather_key="Day_Rain",
        maneuver_start_s=0.0, duration_s=2.0, timeout_s=5.0,  # 2.5 x (0 + 2)
        ego_speed_ms=15.0, init_speed_ms=15.0, ego_end_speed_ms=13.0, final_speed_ms=13.0,
        brake_time_s=2.0,  # never below 0.1 m/s: the whole span
        yellow_delay_s=None, tfl_ds_m=None, tfl_state=None, turn="straight",
        drive_distance_m=27.25, max_speed_ms=15.0, required_lane_sides=[], min_ttc_s=None,
        v_noise_std=0.5, dl_noise_std=0.2, t_noise_std=0.2, **ENVIRONMENT, **NOBODY))


def test_right_turn_slowing_on_green_interpolates_the_yellow_delay():
    # v = 10, 8, 6, 5 m/s; light (green) at 20 m, its 5-m point 15 m lies between 9 m (t=1)
    # and 16 m (t=2): t = 1 + (15 - 9) / (16 - 9) = 1 + 6/7 s
    data = scene("U4_4", [36, 28.8, 21.6, 18], [0, 1, 2, 3], [0, 9, 16, 21.5],
                 light=(20.0, 167))
    _assert_params(_params(data), dict(
        maneuver_tag="turn_right_at_tfl_green", turn="right", tfl_state="green", tfl_ds_m=20.0,
        yellow_delay_s=1.0 + 6.0 / 7.0, brake_time_s=3.0, drive_distance_m=21.5,
        duration_s=3.0, timeout_s=7.5, ego_speed_ms=10.0, init_speed_ms=10.0,
        ego_end_speed_ms=5.0, final_speed_ms=5.0, max_speed_ms=10.0, weather_key="Day_Clear",
        **ENVIRONMENT, **NOBODY))


def test_right_turn_at_night_behind_a_lead_car_with_a_near_light():
    # v = 12, 12, 10, 7, 5 m/s at t = 0, 0.4, 1, 2, 2.5; light at 8 m: its 5-m point (3 m) is
    # reached at 3 / 4.8 x 0.4 = 0.25 s, clamped up to 1 s; the lead starts 18 m ahead at
    # 11 m/s; TTCs 6.0 then 4.5 s (the others unknown, -1) give min_ttc 4.5 s
    v = [12, 12, 10, 7, 5]
    ttc = [6.0, -1.0, 4.5, -1.0, -1.0]
    frames = [[obstacle(5, 18.0 + i, 11.0, v[i], ttc=ttc[i])] for i in range(5)]
    data = scene("U4_4", [x * 3.6 for x in v], [0, 0.4, 1.0, 2.0, 2.5],
                 [100, 104.8, 111.4, 119.9, 122.9], light=(8.0, 167), obstacles=frames,
                 day_period=2)
    _assert_params(_params(data), dict(
        turn="right", tfl_state="green", tfl_ds_m=8.0, yellow_delay_s=1.0, brake_time_s=2.5,
        drive_distance_m=22.9, duration_s=2.5, timeout_s=6.25, ego_speed_ms=12.0,
        init_speed_ms=12.0, ego_end_speed_ms=5.0, final_speed_ms=5.0, weather_key="Night_Clear",
        lead_present=True, lead_distance_m=18.0 + CAR_OVERHANGS_M, lead_speed_ms=11.0,
        lead_vehicle_type="car", has_npc=True, npc_position="front",
        gap_ahead_m=18.0 + CAR_OVERHANGS_M, gap_behind_m=0.0,
        min_ttc_s=4.5, max_speed_ms=12.0, oncoming_present=False, pedestrian_present=False))


def test_straight_on_green_with_a_pedestrian_at_the_crossing():
    # constant 12 m/s, 12 m per second; the 5-m point before the light at 30 m (25 m) is
    # 1/12 of the way from 24 m (t=2) to 36 m (t=3): 2 + 1/12 s
    frames = [[obstacle(9, 30.0 - 12 * i, 0.0, 12.0, rel_lane=2, classification=4, pos_y=4.0)]
              for i in range(3)] + [[], []]
    data = scene("U4_3", [43.2] * 5, REGULAR, [0, 12, 24, 36, 48], light=(30.0, 167),
                 obstacles=frames)
    _assert_params(_params(data), dict(
        maneuver_tag="straight_tfl_green", turn="straight", tfl_state="green", tfl_ds_m=30.0,
        yellow_delay_s=2.0 + 1.0 / 12.0, brake_time_s=4.0, drive_distance_m=48.0,
        duration_s=4.0, timeout_s=10.0, init_speed_ms=12.0, final_speed_ms=12.0,
        pedestrian_present=True, lead_present=False, has_npc=False, npc_position=None,
        max_speed_ms=12.0))


def test_straight_on_green_light_beyond_the_segment_uses_the_start_speed():
    # v = 8.5, 9, 9.5 m/s; the ego covers 36 m but the 5-m point is at 45 m: it is never
    # reached, so yellow_delay = 45 m / 8.5 m/s = 5.294... s (inside [1, 8])
    data = scene("U4_3", [30.6, 32.4, 34.2], [0, 2, 4], [0, 17.5, 36], light=(50.0, 167))
    _assert_params(_params(data), dict(
        yellow_delay_s=45.0 / 8.5, tfl_ds_m=50.0, brake_time_s=4.0, drive_distance_m=36.0,
        duration_s=4.0, timeout_s=10.0, ego_speed_ms=8.5, init_speed_ms=8.5,
        ego_end_speed_ms=9.5, final_speed_ms=9.5, max_speed_ms=9.5, **ENVIRONMENT, **NOBODY))


def test_urban_init_and_final_speed_follow_the_ego_speeds_in_variants():
    from scenweave.ingest import extract_with_variants

    data = scene("U4_2", [36, 36, 36, 30.6], REGULAR[:4], [0, 10, 20, 29], light=(40.0, 167))
    record = canonicalize_scene(data, "U4_2/x.json")
    for v in extract_with_variants(record, 5, seed=3):
        assert v["init_speed_ms"] == v["ego_speed_ms"]
        assert v["final_speed_ms"] == v["ego_end_speed_ms"]

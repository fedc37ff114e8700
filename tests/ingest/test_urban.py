"""Urban canonical records and params, with values worked out by hand (thesis Table 5.1)."""

from __future__ import annotations

import pytest

from ingest import check_record, extract_params
from ingest.urban import canonicalize_scene
from tests.ingest.builders import obstacle, scene

REGULAR = [100.0, 101.0, 102.0, 103.0, 104.0]


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
    assert p["lead_distance_m"] == pytest.approx(25.0)
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

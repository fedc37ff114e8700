"""Property test: any plausible params of any class give a valid scenario that says the params.

Speeds, durations, distances, positions, directions, weather and slot presence are drawn at
random around the hand-written examples; every file must validate against the 1.0 XSD and
read back to the same numbers (docs/scenario-conventions.md).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lxml import etree

from scenweave import corpus
from tests.corpus.conventions import assert_entities_match, assert_storyboard_matches
from tests.corpus.params_examples import TAGS, example_params

speed = st.floats(0.0, 45.0, allow_nan=False)
seconds = st.floats(0.1, 20.0, allow_nan=False)
s_along = st.floats(0.0, 580.0, allow_nan=False)


@st.composite
def params_of_any_class(draw) -> dict:
    code = draw(st.sampled_from(sorted(TAGS)))
    params = example_params(code)
    params |= {"ego_speed_ms": draw(speed), "ego_end_speed_ms": draw(speed),
               "duration_s": draw(seconds),
               "weather_key": draw(st.sampled_from(
                   ["Day_Clear", "Day_Cloudy", "Day_Rain", "Night_Clear", "Night_Rain"]))}
    params["timeout_s"] = 2.5 * (params["maneuver_start_s"] + params["duration_s"])
    for key in [k for k in params if k.endswith(("_speed_ms", "_end_speed_ms"))]:
        if key not in ("ego_speed_ms", "ego_end_speed_ms") and params[key]:
            params[key] = draw(speed)
    for actor in ("ego", "npc", "center", "right", "left"):
        if f"{actor}_s" in params:
            params[f"{actor}_s"] = draw(s_along)
    if "lane_change_direction" in params:
        params["lane_change_direction"] = draw(st.sampled_from(["left", "right"]))
    if code.startswith("U"):
        params |= {"ego_h": draw(st.floats(-3.14, 3.14)), "brake_time_s": draw(seconds)}
        if params["yellow_delay_s"] is not None:
            params["yellow_delay_s"] = draw(st.floats(1.0, 8.0))
        if code == "U4_2":  # a pass: the ego keeps moving and reaches the stop line
            params["tfl_state"] = draw(st.sampled_from(["green", "orange"]))
            params |= {"ego_speed_ms": draw(st.floats(1.0, 25.0)),
                       "ego_end_speed_ms": draw(st.floats(1.0, 25.0))}
        if draw(st.booleans()):
            ahead = draw(st.floats(3.0, 60.0))
            params |= {"lead_present": True, "lead_distance_m": ahead,
                       "lead_speed_ms": draw(speed), "lead_vehicle_type": draw(
                           st.sampled_from(["car", "truck", "van", "motorcycle", "bus"])),
                       "lead_x": params["ego_x"] + ahead * math.cos(params["ego_h"]),
                       "lead_y": params["ego_y"] + ahead * math.sin(params["ego_h"]),
                       "lead_z": params["ego_z"], "lead_h": params["ego_h"]}
    return params


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(params=params_of_any_class())
def test_any_plausible_params_give_a_valid_faithful_scenario(params, xsd_1_0):
    with tempfile.TemporaryDirectory() as out:
        path = corpus.generate(params, Path(out) / "s.xosc")
        doc = etree.parse(str(path))
    assert xsd_1_0.validate(doc), xsd_1_0.error_log
    assert_entities_match(doc, params)
    assert_storyboard_matches(doc, params)

"""The phase model (``scenario_lib.phases``) and how the reference scripts play it (issue 22)."""

from __future__ import annotations

import copy
import math

import pytest
from lxml import etree

from scenweave import corpus
from scenweave.scenario_lib.kinematics import (
    MAX_DECELERATION_MS2,
    SpeedProfile,
    max_deceleration_ms2,
)
from scenweave.scenario_lib.phases import (
    Phase,
    PhasedProfile,
    PhasesInvalid,
    is_single_ramp,
    lane_change_length,
    parse_phases,
    profile_of,
)
from tests.corpus.params_examples import example_params


def _integral(profile: PhasedProfile, t: float, steps: int = 20000) -> float:
    dt = t / steps
    return sum((profile.speed(k * dt) + profile.speed((k + 1) * dt)) / 2 * dt
               for k in range(steps))


@pytest.mark.parametrize("shape", ["linear", "cubic", "sinusoidal", "step"])
def test_distance_is_the_integral_of_speed(shape):
    profile = PhasedProfile(10.0, (Phase(1.0, 2.0, 4.0, shape), Phase(4.0, 1.5, 12.0, shape)))
    for t in (0.5, 1.7, 3.0, 3.5, 4.9, 7.0):
        assert profile.distance(t) == pytest.approx(_integral(profile, t), abs=2e-3)
    assert profile.speed(3.5) == 4.0 and profile.end_speed == 12.0
    assert profile.time_to_cover(profile.distance(4.9)) == pytest.approx(4.9, abs=1e-6)


def test_one_linear_phase_is_the_single_ramp():
    ramp = SpeedProfile(20.0, 14.0, 2.0, 3.0)
    phased = PhasedProfile(20.0, (Phase(2.0, 3.0, 14.0),))
    for t in (0.0, 2.5, 4.0, 6.0):
        assert phased.speed(t) == pytest.approx(ramp.speed(t))
        assert phased.distance(t) == pytest.approx(ramp.distance(t))


@pytest.mark.parametrize("bad, says", [
    ([{"start_s": 1, "duration_s": 2, "target_ms": 3}, {"start_s": 2, "duration_s": 1,
                                                         "target_ms": 3}], "before phase 0"),
    ([{"start_s": 1, "duration_s": -2, "target_ms": 3}], ">= 0"),
    ([{"start_s": 1, "duration_s": 2, "target_ms": 3, "shape": "wobbly"}], "shape"),
    ([{"start_s": 1, "duration_s": 2, "target_ms": math.nan}], "finite"),
    ("fast", "list"),
])
def test_unplayable_phase_lists_are_refused_with_the_reason(bad, says):
    with pytest.raises(PhasesInvalid, match=says):
        parse_phases(bad)


def _params(code: str) -> dict:
    return copy.deepcopy(example_params(code))


def test_a_one_phase_list_equal_to_the_ramp_gives_the_same_bytes(tmp_path):
    params = _params("FLF")
    plain = corpus.generate(params, tmp_path / "plain.xosc").read_bytes()
    params["npc_phases"] = [{"start_s": params["maneuver_start_s"],
                             "duration_s": params["duration_s"],
                             "target_ms": params["npc_end_speed_ms"], "shape": "linear"}]
    assert is_single_ramp(params, "npc")
    assert corpus.generate(params, tmp_path / "one.xosc").read_bytes() == plain


def test_each_phase_is_one_chained_speed_action(tmp_path):
    params = _params("FLF")
    start = params["maneuver_start_s"]
    params["npc_phases"] = [
        {"start_s": start, "duration_s": 1.5, "target_ms": 15.0, "shape": "linear"},
        {"start_s": start + 2.0, "duration_s": 1.0, "target_ms": 18.0, "shape": "cubic"},
        {"start_s": start + 3.0, "duration_s": 2.0, "target_ms": 16.0, "shape": "linear"}]
    root = etree.parse(str(corpus.generate(params, tmp_path / "f.xosc"))).getroot()
    names = ["npc_speed_change", "npc_speed_change_2", "npc_speed_change_3"]
    for name, phase in zip(names, params["npc_phases"], strict=True):
        [action] = root.xpath(f"//Action[@name='{name}']")
        dynamics = action.find(".//SpeedActionDynamics")
        assert float(action.find(".//AbsoluteTargetSpeed").get("value")) == phase["target_ms"]
        assert float(dynamics.get("value")) == phase["duration_s"]
        assert dynamics.get("dynamicsShape") == phase["shape"]
        [condition] = root.xpath(f"//Event[Action/@name='{name}']//ByValueCondition/..")
        assert condition.get("conditionEdge") == "none"
        assert float(condition.find(".//SimulationTimeCondition").get("value")) == \
            phase["start_s"]
    assert not root.xpath("//Action[@name='npc_speed_change_4']")


def test_a_lane_change_during_phases_is_as_long_as_the_profile_drives(tmp_path):
    params = _params("CINF")
    start, duration = params["maneuver_start_s"], params["duration_s"]
    v0 = params["npc_speed_ms"]
    params["npc_phases"] = [{"start_s": start, "duration_s": duration / 2,
                             "target_ms": v0 / 2, "shape": "linear"},
                            {"start_s": start + duration / 2, "duration_s": duration / 2,
                             "target_ms": params["npc_end_speed_ms"], "shape": "linear"}]
    profile = profile_of(params, "npc")
    driven = profile.distance(start + duration) - profile.distance(start)
    assert lane_change_length(params, "npc") == pytest.approx(max(5.0, driven), abs=1e-3)
    root = etree.parse(str(corpus.generate(params, tmp_path / "c.xosc"))).getroot()
    [dynamics] = root.xpath("//Action[@name='npc_lane_change']//LaneChangeActionDynamics")
    assert float(dynamics.get("value")) == lane_change_length(params, "npc")


def test_behind_a_lead_with_phases_the_ego_may_brake_as_hard_as_its_hardest_phase():
    """A lead that brakes at 12 m/s^2 for 0.5 s within a gentle 6 s profile (its mean is
    under 2 m/s^2): the ego is allowed its 12 m/s^2, not the mean's default 8 m/s^2."""
    lead = PhasedProfile(20.0, (Phase(1.0, 0.5, 14.0), Phase(4.0, 3.0, 12.0)))
    assert lead.hardest_braking_ms2() == pytest.approx(12.0)
    assert max_deceleration_ms2(lead) == pytest.approx(12.0)
    assert max_deceleration_ms2(SpeedProfile(20.0, 12.0, 1.0, 6.0)) == MAX_DECELERATION_MS2
    assert max_deceleration_ms2(SpeedProfile(20.0, 12.0, 1.0, 0.0)) == math.inf

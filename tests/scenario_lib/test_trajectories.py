"""The in-situ scenario as written: trajectories with vertex times, absolute timing, position
mode, boxes centred on the recorded centre, parked vehicles, the external hero, XSD 1.0."""

from __future__ import annotations

import math

import pytest
from lxml import etree

from scenweave.scenario_lib.builder import write_scenario
from scenweave.scenario_lib.trajectories import (
    InSituScene,
    RecordedVehicle,
    SignalController,
    SignalPhase,
    hold_backward,
    in_situ_scenario,
    reference_csv,
)
from scenweave.schemas.xsd import osc_1_0_schema


def _vehicle(name: str, start: float, n: int, x0: float = 0.0, speed: float = 10.0,
             **kw) -> RecordedVehicle:
    times = [round(start + 0.1 * k, 3) for k in range(n)]
    return RecordedVehicle(name, kw.pop("kind", "car"), kw.pop("length", 4.4), 1.9, times,
                           [x0 + speed * (t - start) for t in times], [-1.75] * n, [0.0] * n,
                           **kw)


def _scene(**kw) -> InSituScene:
    vehicles = [_vehicle("hero", 0.0, 31, properties={"track_id": "7"}),
                _vehicle("v12", 1.0, 11, x0=40.0, kind="truck", length=12.0)]
    return InSituScene("test", "road.xodr", 3.0, vehicles, (0.0, -150.0),
                       controllers=[SignalController("light_1", [
                           SignalPhase(1.5, {"5": "green"}), SignalPhase(1.5, {"5": "red"})])],
                       **kw)


@pytest.fixture
def written(tmp_path):
    def write(**kw) -> etree._Element:
        path = write_scenario(in_situ_scenario(_scene(**kw)), tmp_path / "s.xosc")
        tree = etree.parse(str(path))
        schema = osc_1_0_schema()
        assert schema.validate(tree), list(schema.error_log)
        return tree.getroot()
    return write


def test_every_vehicle_follows_its_record_with_absolute_vertex_times(written):
    root = written()
    assert root.find("FileHeader").get("revMinor") == "0"
    assert root.find("RoadNetwork/LogicFile").get("filepath") == "road.xodr"
    follows = {next(a.iterancestors("ManeuverGroup")).find("Actors/EntityRef")
               .get("entityRef"): a for a in root.iter("FollowTrajectoryAction")}
    assert set(follows) == {"hero", "v12"}
    truck = follows["v12"]
    timing = truck.find("TimeReference/Timing")
    assert timing.get("domainAbsoluteRelative") == "absolute"
    assert (float(timing.get("scale")), float(timing.get("offset"))) == (1.0, 0.0)
    assert truck.find("TrajectoryFollowingMode").get("followingMode") == "position"
    vertices = truck.findall(".//Polyline/Vertex")
    assert [float(v.get("time")) for v in vertices] == pytest.approx(
        [1.0 + 0.1 * k for k in range(11)])
    assert float(vertices[-1].find("Position/WorldPosition").get("x")) == pytest.approx(50.0)


def test_boxes_are_the_recorded_size_centred_on_the_reference_point(written):
    root = written()
    truck = root.find("Entities/ScenarioObject[@name='v12']/Vehicle")
    assert truck.get("vehicleCategory") == "truck"
    centre = truck.find("BoundingBox/Center")
    assert (float(centre.get("x")), float(centre.get("y"))) == (0.0, 0.0)
    assert float(truck.find("BoundingBox/Dimensions").get("length")) == 12.0
    hero = root.find("Entities/ScenarioObject[@name='hero']/Vehicle")
    properties = {p.get("name"): p.get("value") for p in hero.iter("Property")}
    assert properties == {"type": "ego_vehicle", "plineInterpolation": "segment",
                          "track_id": "7"}


def test_a_late_vehicle_waits_parked_and_leaves_when_its_track_ends(written):
    root = written()
    init = root.find("Storyboard/Init/Actions/Private[@entityRef='v12']")
    parked = init.find(".//TeleportAction//WorldPosition")
    assert float(parked.get("y")) < -100  # away from the recorded traffic
    events = {e.get("name"): e for e in root.iter("Event")}
    appears = events["v12_follows_record"]
    assert appears.find(".//TeleportAction") is not None
    start = float(appears.find(".//SimulationTimeCondition").get("value"))
    assert 0.89 < start < 0.9  # one recorded step early: it stands on its first pose
    leaves = events["v12_leaves"]
    assert float(leaves.find(".//SimulationTimeCondition").get("value")) == pytest.approx(2.0,
                                                                                         abs=0.01)
    assert "hero_leaves" not in events  # its track lasts the whole scenario


def test_the_lights_are_controllers_of_the_recorded_phases(written):
    root = written()
    phases = root.findall("RoadNetwork/TrafficSignals/TrafficSignalController/Phase")
    assert [(float(p.get("duration")), p.find("TrafficSignalState").get("state"))
            for p in phases] == [(1.5, "green"), (1.5, "red")]
    assert phases[0].find("TrafficSignalState").get("trafficSignalId") == "5"


def test_the_external_hero_is_handed_to_the_stack_and_keeps_its_reference(written):
    root = written(external=True, reference_file="hero_reference.csv")
    hero = root.find("Storyboard/Init/Actions/Private[@entityRef='hero']")
    controller = hero.find(".//ControllerAction/AssignControllerAction/Controller")
    properties = {p.get("name"): p.get("value") for p in controller.iter("Property")}
    assert properties["module"] == "external_control"
    assert properties["esminiController"] == "ExternalController"
    assert hero.find(".//ControllerAction/OverrideControllerValueAction/Throttle") is not None
    assert not [g for g in root.iter("ManeuverGroup")
                if g.find("Actors/EntityRef").get("entityRef") == "hero"]
    entity = root.find("Entities/ScenarioObject[@name='hero']/Vehicle")
    assert {p.get("name"): p.get("value") for p in entity.iter("Property")}[
        "reference_trajectory"] == "hero_reference.csv"


def test_the_reference_is_the_recorded_trajectory():
    vehicle = _vehicle("hero", 0.0, 3)
    assert reference_csv(vehicle.times, vehicle.x, vehicle.y,
                         vehicle.heading).splitlines() == [
        "t,x,y,h", "0.000,0.000,-1.750,0.0000", "0.100,1.000,-1.750,0.0000",
        "0.200,2.000,-1.750,0.0000"]


def test_standstill_jitter_is_held_and_forward_steps_kept():
    x = [10.0, 10.2, 9.9, 10.25, 10.1, 11.0, 12.0]
    y = [0.0, 0.0, 0.05, 0.0, 0.0, 0.0, 0.0]
    heading = [0.0] * 7
    held_x, held_y, held = hold_backward(x, y, heading)
    assert all(b >= a for a, b in zip(held_x, held_x[1:], strict=False))  # never backwards
    # the closest such path: each backward step split evenly between its two samples
    assert held_x == pytest.approx([10.0, 10.05, 10.05, 10.175, 10.175, 11.0, 12.0])
    assert held_y == pytest.approx(y)  # sideways jitter stays
    assert held == [False, True, True, True, True, False, False]


def test_a_record_that_never_reverses_is_played_as_recorded():
    x = [0.0, 0.0, 0.5, 1.5, 1.5, 3.0]
    held_x, held_y, held = hold_backward(x, [1.0] * 6, [0.0] * 6)
    assert held_x == x and held_y == [1.0] * 6 and not any(held)


def test_a_heading_against_the_motion_holds_along_the_heading():
    heading = [math.pi] * 3  # driving towards -x
    held_x, _, held = hold_backward([5.0, 4.0, 4.3], [0.0] * 3, heading)
    assert held_x == pytest.approx([5.0, 4.15, 4.15]) and held == [False, True, True]


def test_a_vehicle_without_a_size_or_samples_is_no_trajectory():
    with pytest.raises(ValueError, match="length"):
        _vehicle("v1", 0.0, 3, length=float("nan"))
    with pytest.raises(ValueError, match="two samples"):
        _vehicle("v1", 0.0, 1)

"""Recorded traffic as OpenSCENARIO 1.0: every vehicle follows its recorded trajectory.

The *in-situ* form of a mined event (``mining.in_situ`` chooses what to play): every vehicle
recorded around the event, on the recorded road, each a ``FollowTrajectoryAction`` along a
``Polyline`` with one vertex per recorded sample and its time, ``Timing
domainAbsoluteRelative="absolute" scale="1" offset="0"`` (a vertex's time is the scenario's
time) and ``followingMode="position"`` (the player puts the car on the line, no controller
smooths it). The bounding box is centred on the reference point, so the recorded centre is
where the car is.

Appearing and leaving: a vehicle whose track starts after t = 0 waits *parked* (teleported in
Init to its own slot of a row well away from the recorded traffic, standing) until its first
recorded time, when an event teleports it onto its first recorded pose and starts its
trajectory; a vehicle whose track ends before the scenario does is teleported back to its
slot and stopped. OpenSCENARIO 1.0 also has ``AddEntityAction``/``DeleteEntityAction`` (and
esmini 3.6 keeps an entity without Init actions out of the scene until added), but CARLA's
scenario_runner spawns every entity when the scenario starts and ScenWeave's player records a
fixed set of entities, so a parked car is what both play alike.

Traffic lights: one ``TrafficSignalController`` per recorded light, its phases the recorded
states over the scenario's time (state names as CARLA writes them: green, yellow, red).

The ego (``hero``, ``type=ego_vehicle``) either follows its record like everyone else or, when
``external`` is set, is handed to an external controller (scenario_runner's
``external_control`` module, esmini's ``ExternalController``) in Init, starting at its first
recorded pose and speed; its recorded trajectory then travels beside the scenario as the
reference (a property names the file).

Imports nothing of ScenWeave's outside this folder (the sandbox mounts it alone).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from scenariogeneration import xosc

from scenweave.scenario_lib.builder import AUTHOR, HEADER_DATE, HERO, at_time
from scenweave.scenario_lib.vehicles import PERFORMANCE_MAX_SPEED_MS, VEHICLE_MODELS, known_type

#: a time condition is "greater than" and the player's clock lands on recorded times: a
#: trigger set this much before a time fires at it (s)
TRIGGER_EPS_S = 1e-3
#: parked cars stand this far apart bumper to bumper (m), rows of this many, rows this far
#: apart (m)
PARKING_GAP_M = 5.0
PARKING_ROW = 40
PARKING_ROW_SPACING_M = 20.0
#: the scenario's decimals: positions to the millimetre, headings to 1e-4 rad, times to 1 ms
POSITION_DIGITS = 3
HEADING_DIGITS = 4
TIME_DIGITS = 3
#: a recorded step less than this against the heading is no step backwards (m)
BACKWARD_EPS_M = 1e-3
#: the external controller, as scenario_runner (module) and esmini (esminiController) name it
EXTERNAL_MODULE = "external_control"
ESMINI_EXTERNAL = "ExternalController"
#: accelerations a trajectory follower may show (m/s2): position mode ignores them, but a
#: player must not cap what was recorded
PERFORMANCE_ACCELERATION_MS2 = 30.0


@dataclass(frozen=True)
class RecordedVehicle:
    """One vehicle as recorded: its name in the scenario, size, kind and samples.

    ``times`` are scenario times (s, increasing), ``x``/``y`` the box centre in the map's
    frame (m), ``heading`` (rad); ``properties`` are written on the vehicle (the ego's track
    id, say)."""

    name: str
    vehicle_type: str
    length_m: float
    width_m: float
    times: Sequence[float]
    x: Sequence[float]
    y: Sequence[float]
    heading: Sequence[float]
    properties: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.times)
        if n < 2:
            raise ValueError(f"{self.name}: a trajectory needs two samples or more, not {n}")
        if not (len(self.x) == len(self.y) == len(self.heading) == n):
            raise ValueError(f"{self.name}: times, x, y and heading differ in length")
        if any(b <= a for a, b in zip(self.times, self.times[1:], strict=False)):
            raise ValueError(f"{self.name}: sample times must increase")
        for what, value in (("length", self.length_m), ("width", self.width_m)):
            if not math.isfinite(value) or value <= 0:
                raise ValueError(f"{self.name}: {what} must be a positive number, not {value!r}")

    @property
    def start_s(self) -> float:
        return float(self.times[0])

    @property
    def end_s(self) -> float:
        return float(self.times[-1])

    @property
    def start_speed_ms(self) -> float:
        """The speed over the first recorded step (m/s)."""
        dt = self.times[1] - self.times[0]
        return math.hypot(self.x[1] - self.x[0], self.y[1] - self.y[0]) / dt


@dataclass(frozen=True)
class SignalPhase:
    """A light's state for ``duration_s``: signal id -> state (green, yellow, red, off)."""

    duration_s: float
    states: Mapping[str, str]


@dataclass(frozen=True)
class SignalController:
    """A recorded traffic light's timeline as one controller's phases, from t = 0."""

    name: str
    phases: Sequence[SignalPhase]


@dataclass(frozen=True)
class InSituScene:
    """Everything an in-situ scenario holds.

    ``parking`` is the first parking slot (x, y); slots run along +x from there. ``external``
    hands the hero to an external controller; ``reference_file`` then names where its
    recorded trajectory is kept (a property of ``hero``)."""

    description: str
    road_file: str
    duration_s: float
    vehicles: Sequence[RecordedVehicle]
    parking: tuple[float, float]
    #: the recording's time step (s): a player evaluates a time condition at the start of a
    #: step and moves the car at its end, so a car appears when the clock reads one step
    #: before its first recorded time (it then stands on its first pose until that time)
    step_s: float = 0.1
    controllers: Sequence[SignalController] = ()
    external: bool = False
    reference_file: str | None = None


def in_situ_scenario(scene: InSituScene) -> xosc.Scenario:
    """The OpenSCENARIO 1.0 scenario of ``scene`` (write it with ``builder.write_scenario``)."""
    names = [v.name for v in scene.vehicles]
    if len(set(names)) != len(names):
        raise ValueError("vehicle names must be unique")
    entities = xosc.Entities()
    init = xosc.Init()
    # a time condition is "greater than": the act starts at the first step only when its
    # time lies before 0 (at 0 it would start, and its events run, one step late)
    act = xosc.Act("in_situ_act", at_time("act_start", -scene.step_s),
                   at_time("act_stop", scene.duration_s, "stop"))
    slots = _parking_slots(scene.parking, scene.vehicles)
    for vehicle, parked in zip(scene.vehicles, slots, strict=True):
        external = scene.external and vehicle.name == HERO
        entities.add_scenario_object(vehicle.name, _vehicle(vehicle, scene, external))
        _init_actions(init, vehicle, parked, external)
        group = _maneuver_group(vehicle, parked, scene, external)
        if group is not None:
            act.add_maneuver_group(group)
    story = xosc.Story("in_situ_story")
    story.add_act(act)
    storyboard = xosc.StoryBoard(init, at_time("timeout", scene.duration_s, "stop"))
    storyboard.add_story(story)
    road_network = xosc.RoadNetwork(scene.road_file)
    for controller in scene.controllers:
        road_network.add_traffic_signal_controller(_controller(controller))
    return xosc.Scenario(scene.description, AUTHOR, xosc.ParameterDeclarations(), entities,
                         storyboard, road_network, xosc.Catalog(), osc_minor_version=0,
                         creation_date=HEADER_DATE)


def _vehicle(vehicle: RecordedVehicle, scene: InSituScene, external: bool) -> xosc.Vehicle:
    """The vehicle with its recorded size, the box centred on the reference point."""
    model = VEHICLE_MODELS[known_type(vehicle.vehicle_type)]
    box = xosc.BoundingBox(vehicle.width_m, vehicle.length_m, model.height_m, 0, 0,
                           model.height_m / 2)
    # the rear axle at x = 0: esmini moves the reference point (and the box) onto a rear axle
    # placed anywhere else, and the recorded centre must stay the reference point
    front = xosc.Axle(0.5, 0.7, vehicle.width_m * 0.85, vehicle.length_m * 0.6, 0.35)
    rear = xosc.Axle(0.0, 0.7, vehicle.width_m * 0.85, 0.0, 0.35)
    entry = xosc.Vehicle(model.blueprint, xosc.VehicleCategory[model.category], box, front, rear,
                         PERFORMANCE_MAX_SPEED_MS, PERFORMANCE_ACCELERATION_MS2,
                         PERFORMANCE_ACCELERATION_MS2)
    if vehicle.name == HERO:
        entry.add_property("type", "ego_vehicle")
    # esmini turns a car at each vertex by default ("corner"); "segment" interpolates the
    # heading from one recorded sample's to the next, so at a sample it is the recorded one
    entry.add_property("plineInterpolation", "segment")
    for key, value in vehicle.properties.items():
        entry.add_property(key, value)
    if external and scene.reference_file:
        entry.add_property("reference_trajectory", scene.reference_file)
    return entry


def _pose(vehicle: RecordedVehicle, k: int) -> xosc.WorldPosition:
    return xosc.WorldPosition(round(vehicle.x[k], POSITION_DIGITS),
                              round(vehicle.y[k], POSITION_DIGITS), 0,
                              round(vehicle.heading[k], HEADING_DIGITS))


def _parking_slots(first: tuple[float, float],
                   vehicles: Sequence[RecordedVehicle]) -> list[xosc.WorldPosition]:
    """One slot per vehicle, in rows of ``PARKING_ROW`` along +x, each car
    ``PARKING_GAP_M`` behind the one before whatever their lengths (a bus is 15 m long)."""
    slots, x, y = [], first[0], first[1]
    for slot, vehicle in enumerate(vehicles):
        if slot and slot % PARKING_ROW == 0:
            x, y = first[0], y - PARKING_ROW_SPACING_M
        x += vehicle.length_m / 2
        slots.append(xosc.WorldPosition(round(x, POSITION_DIGITS), y, 0, 0))
        x += vehicle.length_m / 2 + PARKING_GAP_M
    return slots


def _speed(speed_ms: float) -> xosc.AbsoluteSpeedAction:
    """Set at once (a step)."""
    return xosc.AbsoluteSpeedAction(round(speed_ms, 3), xosc.TransitionDynamics(
        xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0))


def _init_actions(init: xosc.Init, vehicle: RecordedVehicle, parked: xosc.WorldPosition,
                  external: bool) -> None:
    """Where each vehicle is at t = 0: on its first pose, at its first speed, if recorded
    then (the speed carries it through the first step, before the story's events run), else
    parked."""
    if vehicle.start_s > TRIGGER_EPS_S and not external:
        init.add_init_action(vehicle.name, xosc.TeleportAction(parked))
        init.add_init_action(vehicle.name, _speed(0.0))
        return
    init.add_init_action(vehicle.name, xosc.TeleportAction(_pose(vehicle, 0)))
    init.add_init_action(vehicle.name, _speed(vehicle.start_speed_ms))
    if external:
        init.add_init_action(vehicle.name, _external_controller())


def _external_controller() -> xosc.ControllerAction:
    """The stack under test drives the hero: scenario_runner's ``external_control`` module,
    esmini's ExternalController; no value is overridden."""
    properties = xosc.Properties()
    properties.add_property("module", EXTERNAL_MODULE)
    properties.add_property("esminiController", ESMINI_EXTERNAL)
    controller = xosc.Controller("HeroAgent", properties)
    untouched = xosc.OverrideControllerValueAction()  # OpenSCENARIO 1.0 requires all six
    for name in ("throttle", "brake", "clutch", "parkingbrake", "steeringwheel", "gear"):
        getattr(untouched, f"set_{name}")(False, 0)
    return xosc.ControllerAction(xosc.AssignControllerAction(controller), untouched)


def _maneuver_group(vehicle: RecordedVehicle, parked: xosc.WorldPosition, scene: InSituScene,
                    external: bool) -> xosc.ManeuverGroup | None:
    """The vehicle's events: appear and follow the record, then leave (park) when its track
    ends before the scenario; none for an externally driven hero.

    A player evaluates a time condition at the start of a step and moves the car during it:
    a car appearing at ``t`` is triggered one ``step_s`` earlier (it stands on its first pose
    until ``t``: absolute timing), a car leaving after ``t`` is triggered at ``t``."""
    if external:
        return None
    maneuver = xosc.Maneuver(f"{vehicle.name}_maneuver")
    follow = xosc.Event(f"{vehicle.name}_follows_record", xosc.Priority.parallel)
    if vehicle.start_s > TRIGGER_EPS_S:
        follow.add_action(f"{vehicle.name}_appears", xosc.TeleportAction(_pose(vehicle, 0)))
    follow.add_action(f"{vehicle.name}_trajectory", _follow(vehicle))
    follow.add_trigger(at_time(f"{vehicle.name}_start",
                               vehicle.start_s - scene.step_s - TRIGGER_EPS_S))
    maneuver.add_event(follow)
    if vehicle.end_s < scene.duration_s - TRIGGER_EPS_S:
        leave = xosc.Event(f"{vehicle.name}_leaves", xosc.Priority.parallel)
        leave.add_action(f"{vehicle.name}_parks", xosc.TeleportAction(parked))
        leave.add_action(f"{vehicle.name}_stands", _speed(0.0))
        leave.add_trigger(at_time(f"{vehicle.name}_end", vehicle.end_s - TRIGGER_EPS_S))
        maneuver.add_event(leave)
    group = xosc.ManeuverGroup(f"{vehicle.name}_group")
    group.add_actor(vehicle.name)
    group.add_maneuver(maneuver)
    return group


def _follow(vehicle: RecordedVehicle) -> xosc.FollowTrajectoryAction:
    times = [round(float(t), TIME_DIGITS) for t in vehicle.times]
    line = xosc.Polyline(times, [_pose(vehicle, k) for k in range(len(times))])
    trajectory = xosc.Trajectory(f"{vehicle.name}_record", False)
    trajectory.add_shape(line)
    return xosc.FollowTrajectoryAction(trajectory, xosc.FollowingMode.position,
                                       xosc.ReferenceContext.absolute, 1, 0)


def _controller(controller: SignalController) -> xosc.TrafficSignalController:
    signals = xosc.TrafficSignalController(controller.name)
    for number, phase in enumerate(controller.phases):
        entry = xosc.Phase(f"{controller.name}_{number}", round(phase.duration_s, TIME_DIGITS))
        for signal_id, state in phase.states.items():
            entry.add_signal_state(signal_id, state)
        signals.add_phase(entry)
    return signals


def hold_backward(x: Sequence[float], y: Sequence[float],
                  heading: Sequence[float]) -> tuple[list[float], list[float], list[bool]]:
    """The positions a trajectory plays: the recorded ones moved along the heading as little
    as possible (least squares) for the car never to step backwards. Where a standing car's
    recorded position jitters backwards (NGSIM: up to 1 m and back within a second, its
    ``velocity`` saying it drives on), the car holds between the jittered positions instead
    of reversing; sideways jitter and every stretch that moves forward stay as recorded.

    The progress along the heading, summed step by step, is fitted by the closest
    non-decreasing sequence (pool-adjacent-violators); each position moves along its heading
    by the fit's difference. Also, per sample, whether it lies off the record (held)."""
    if not len(x):
        return [], [], []
    progress = [0.0]
    for k in range(1, len(x)):
        step = ((x[k] - x[k - 1]) * math.cos(heading[k])
                + (y[k] - y[k - 1]) * math.sin(heading[k]))
        progress.append(progress[-1] + step)
    fitted = _non_decreasing(progress)
    out_x, out_y, held = [], [], []
    for k, (want, got) in enumerate(zip(fitted, progress, strict=True)):
        shift = want - got if abs(want - got) > BACKWARD_EPS_M else 0.0
        out_x.append(float(x[k]) + shift * math.cos(heading[k]))
        out_y.append(float(y[k]) + shift * math.sin(heading[k]))
        held.append(bool(shift != 0.0))
    return out_x, out_y, held


def _non_decreasing(values: Sequence[float]) -> list[float]:
    """The non-decreasing sequence closest to ``values`` in least squares (pool adjacent
    violators: a block that falls below the one before merges with it into their mean)."""
    blocks: list[list[float]] = []  # [mean, count]
    for value in values:
        blocks.append([value, 1.0])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            mean, count = blocks.pop()
            total = blocks[-1][1] + count
            blocks[-1] = [(blocks[-1][0] * blocks[-1][1] + mean * count) / total, total]
    return [mean for mean, count in blocks for _ in range(int(count))]


def reference_csv(times: Sequence[float], x: Sequence[float], y: Sequence[float],
                  heading: Sequence[float]) -> str:
    """A recorded trajectory as CSV (``t,x,y,h``): the reference an externally driven hero
    is measured against, every recorded sample."""
    rows = ["t,x,y,h"] + [f"{t:.3f},{a:.3f},{b:.3f},{h:.4f}" for t, a, b, h in
                          zip(times, x, y, heading, strict=True)]
    return "\n".join(rows) + "\n"


def scenario_summary(scene: InSituScene) -> dict[str, Any]:
    """How many vehicles, how many appear late or leave early, how long (for reports)."""
    late = sum(v.start_s > TRIGGER_EPS_S for v in scene.vehicles)
    early = sum(v.end_s < scene.duration_s - TRIGGER_EPS_S for v in scene.vehicles)
    return {"vehicles": len(scene.vehicles), "appear_later": late, "leave_earlier": early,
            "duration_s": scene.duration_s, "lights": len(scene.controllers),
            "external_hero": scene.external}

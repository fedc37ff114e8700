"""The vehicles a scenario may hold: CARLA blueprints, their OpenSCENARIO category and size, and
the gaps between them, bumper to bumper or reference point to reference point.

Pure arithmetic on the vehicle table, so that the stages measuring gaps (ingest, the viewer,
the replay figure) need not load the scenario builder and ``scenariogeneration`` (with SciPy,
half a second) to ask how long a truck is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scenweave.scenario_lib.kinematics import SAFETY_GAP_M


@dataclass(frozen=True)
class VehicleModel:
    """A CARLA blueprint with the OpenSCENARIO category and dimensions that describe it."""

    blueprint: str
    #: an OpenSCENARIO 1.0 VehicleCategory (``car``, ``truck``, ``van``, ``motorbike``...)
    category: str
    length_m: float
    width_m: float
    height_m: float
    max_speed_ms: float


#: the Performance maxSpeed of every model (m/s, 250 km/h): players cap an actor at it, and a
#: record may show any vehicle (a truck at 130 km/h included) faster than its model's real top
#: speed; the scenario must play what was recorded
PERFORMANCE_MAX_SPEED_MS = 69.0

#: the bounding box's centre lies this share of the length ahead of the reference point (the
#: rear axle, where TeleportAction puts a vehicle)
BOX_CENTRE_AHEAD = 0.3

VEHICLE_MODELS: dict[str, VehicleModel] = {
    "ego": VehicleModel("vehicle.tesla.model3", "car", 4.8, 2.1, 1.5, PERFORMANCE_MAX_SPEED_MS),
    "car": VehicleModel("vehicle.audi.a2", "car", 3.7, 1.8, 1.6, PERFORMANCE_MAX_SPEED_MS),
    "truck": VehicleModel("vehicle.carlamotors.carlacola", "truck", 5.2, 2.6, 2.5,
                          PERFORMANCE_MAX_SPEED_MS),
    "van": VehicleModel("vehicle.mercedes.sprinter", "van", 5.9, 2.0, 2.6,
                        PERFORMANCE_MAX_SPEED_MS),
    "motorcycle": VehicleModel("vehicle.yamaha.yzf", "motorbike", 2.2, 0.9, 1.5,
                               PERFORMANCE_MAX_SPEED_MS),
}


#: the least free space between two cars' facing bumpers in one lane, ahead or behind (m):
#: less and a played scenario's bounding boxes touch within the replay's tolerances
MIN_BUMPER_GAP_M = 0.5


def reference_gap_m(bumper_gap_m: float, other_type: str | None) -> float:
    """The distance between the ego's and another vehicle's reference points when the free
    space between their facing bumpers is ``bumper_gap_m`` (positive: the other ahead, its rear
    facing the ego's front; negative: behind, its front facing the ego's rear). A gap of 0 is
    side by side, and its sign says which: a record of a car about to drop back writes -0.0
    (issue 36: a CINB taken for a car ahead cut in on the ego's flank)."""
    ego, other = VEHICLE_MODELS["ego"].length_m, VEHICLE_MODELS[known_type(other_type)].length_m
    if math.copysign(1.0, bumper_gap_m) > 0:
        return bumper_gap_m + _front_of(ego) + _rear_of(other)
    return bumper_gap_m - _rear_of(ego) - _front_of(other)


def bumper_gap_m(reference_m: float, other_type: str | None) -> float | None:
    """The free space between the facing bumpers of the ego and a vehicle of ``other_type``
    whose reference point is ``reference_m`` ahead (negative: behind): ``reference_gap_m``
    undone. ``None`` when the two overlap along the lane (side by side: no facing bumpers)."""
    ego, other = VEHICLE_MODELS["ego"].length_m, VEHICLE_MODELS[known_type(other_type)].length_m
    if reference_m >= _front_of(ego) + _rear_of(other):
        return reference_m - _front_of(ego) - _rear_of(other)
    if reference_m <= -(_rear_of(ego) + _front_of(other)):
        return reference_m + _rear_of(ego) + _front_of(other)
    return None


def least_reference_gap_m(other_type: str | None, ahead: bool) -> float:
    """The reference-point distance at which the facing bumpers of the ego and a vehicle of
    ``other_type`` are ``MIN_BUMPER_GAP_M`` apart (the reference point is the rear axle, so
    it differs ahead and behind)."""
    return abs(reference_gap_m(MIN_BUMPER_GAP_M if ahead else -MIN_BUMPER_GAP_M, other_type))


def ego_front_m() -> float:
    """How far the ego's front bumper lies ahead of its reference point, the point a spawn
    places (m)."""
    return _front_of(VEHICLE_MODELS["ego"].length_m)


def _front_of(length_m: float) -> float:
    """How far the front bumper lies ahead of the reference point (the box centre is
    ``BOX_CENTRE_AHEAD`` x length ahead of it)."""
    return length_m * (BOX_CENTRE_AHEAD + 0.5)


def _rear_of(length_m: float) -> float:
    return length_m * (0.5 - BOX_CENTRE_AHEAD)


def clearance_m(other_type: str | None) -> float:
    """The distance the ego and a vehicle of ``other_type`` keep, reference point to reference
    point in one lane: half of both lengths plus ``SAFETY_GAP_M``."""
    lengths = VEHICLE_MODELS["ego"].length_m + VEHICLE_MODELS[known_type(other_type)].length_m
    return lengths / 2 + SAFETY_GAP_M


def known_type(vehicle_type: str | None) -> str:
    """``vehicle_type`` when it has a CARLA model here, else ``car``."""
    return vehicle_type if vehicle_type in VEHICLE_MODELS else "car"

"""Traffic lights and stop lines as seen from a lane that enters a junction.

A junction's connecting roads carry ``<signalReference>`` records naming the light that
controls each of their lanes; the physical light is the ``<signal>`` with that id, standing
somewhere on the map. A lane that ends at a junction therefore has, per movement (straight,
left, right), a controlling light. Its stop line is where the lane ends and the junction
begins (Town04's light poles stand 5-25 m past it).
"""

from __future__ import annotations

from dataclasses import dataclass

from scenweave.roads.lanes import WorldPose, point_at
from scenweave.roads.opendrive import Signal
from scenweave.roads.road_network import LaneKey, RoadNetwork

#: OpenDRIVE signal type of a traffic light (as CARLA writes it)
TRAFFIC_LIGHT_TYPE = "1000001"


@dataclass(frozen=True)
class ControlledMovement:
    """One movement out of a lane through a junction, and the light controlling it."""

    movement: str
    connecting_lane: LaneKey
    signal: Signal | None


@dataclass(frozen=True)
class JunctionApproach:
    """What a lane that ends at a junction leads to."""

    junction_id: str
    movements: tuple[ControlledMovement, ...]
    stop_line_s: float

    @property
    def signalised(self) -> bool:
        """Whether some movement out of the lane is controlled by a traffic light."""
        return any(m.signal is not None for m in self.movements)


def signal_position(network: RoadNetwork, signal: Signal) -> WorldPose:
    """World position of a signal (OpenDRIVE frame): its ``(s, t)`` on its road."""
    return point_at(network.road(signal.road_id), signal.s, signal.t)


def is_traffic_light(signal: Signal) -> bool:
    """Whether a signal is a dynamic traffic light."""
    return signal.dynamic and (signal.type == TRAFFIC_LIGHT_TYPE or "light" in signal.name.lower())


def junction_approach(network: RoadNetwork, key: LaneKey) -> JunctionApproach | None:
    """The junction this lane section runs into, or ``None`` if it does not end at one."""
    return network.remembered("approach", key, lambda: _find_approach(network, key))


def _find_approach(network: RoadNetwork, key: LaneKey) -> JunctionApproach | None:
    targets = network.successors(key)
    junction_roads = network.junction_roads
    if not targets or any(t.road_id not in junction_roads for t in targets):
        return None
    movements = tuple(ControlledMovement(network.movement(t), t, _controlling_light(network, t))
                      for t in targets)
    junction_id = network.road(targets[0].road_id).junction
    return JunctionApproach(junction_id, movements, network.exit_s(key))


def _controlling_light(network: RoadNetwork, key: LaneKey) -> Signal | None:
    road = network.road(key.road_id)
    for reference in [*road.signal_references, *road.signals]:
        if any(min(a, b) <= key.lane_id <= max(a, b) for a, b in reference.valid_lanes):
            signal = network.map.signal(reference.id) if reference.reference_only else reference
            if is_traffic_light(signal):
                return signal
    return None

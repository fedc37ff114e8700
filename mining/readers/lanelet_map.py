"""A recording's lane network in the neutral model of ``roads.recorded_road``: CommonRoad
lanelets (read with ``commonroad-io``) become :class:`LaneStrip`\\ s, its traffic lights
:class:`RecordedLight`\\ s with their stop lines, their recorded cycles :class:`LightPhase`\\ s.

Only the map is read here (obstacles and planning problems are taken out of the XML first, as
the trajectory reader does), so converting a recording's road costs no trajectory parsing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork, LaneletType
from lxml import etree

from scenweave.mining.readers.commonroad import _network, _stop_line, light_phases
from scenweave.mining.tracks import LightPhase
from scenweave.roads.recorded_road import LaneStrip, RecordedLight

#: CommonRoad lanelet types that are no lane for cars, as OpenDRIVE lane types
LANE_TYPES = {LaneletType.SIDEWALK: "sidewalk", LaneletType.CROSSWALK: "sidewalk",
              LaneletType.BICYCLE_LANE: "biking", LaneletType.SHOULDER: "shoulder",
              LaneletType.PARKING: "parking", LaneletType.BORDER: "border",
              LaneletType.RESTRICTED: "restricted", LaneletType.RESTRICTED_AREA: "restricted"}


@dataclass(frozen=True)
class LaneletMap:
    """One file's lane network: strips, lights and each light's recorded cycle."""

    source: str
    strips: tuple[LaneStrip, ...]
    lights: tuple[RecordedLight, ...]
    #: light id -> its colours over the recording (red, yellow, green runs)
    phases: dict[str, tuple[LightPhase, ...]]
    dt: float


def lane_type(lanelet: Lanelet) -> str:
    """The OpenDRIVE lane type of a lanelet: ``driving`` unless every type it has says it is
    no lane for cars."""
    types = set(lanelet.lanelet_type or ())
    named = {LANE_TYPES[t] for t in types if t in LANE_TYPES}
    return min(named) if named and len(named) == len(types) else "driving"


def lane_strip(lanelet: Lanelet) -> LaneStrip:
    """One lanelet as a strip (ids as text)."""
    def ref(value: int | None) -> str | None:
        return None if value is None else str(value)

    return LaneStrip(
        id=str(lanelet.lanelet_id),
        left=np.asarray(lanelet.left_vertices, dtype=float),
        right=np.asarray(lanelet.right_vertices, dtype=float),
        predecessors=tuple(str(i) for i in lanelet.predecessor),
        successors=tuple(str(i) for i in lanelet.successor),
        left_neighbour=ref(lanelet.adj_left),
        left_same_direction=bool(lanelet.adj_left_same_direction),
        right_neighbour=ref(lanelet.adj_right),
        right_same_direction=bool(lanelet.adj_right_same_direction),
        lane_type=lane_type(lanelet))


def recorded_lights(network: LaneletNetwork) -> list[RecordedLight]:
    """Every traffic light with the lanelets that reference it and their stop lines."""
    lights = []
    for light in network.traffic_lights:
        lanelets = [ll for ll in network.lanelets if light.traffic_light_id in ll.traffic_lights]
        position = getattr(light, "position", None)
        lights.append(RecordedLight(
            id=str(light.traffic_light_id),
            strips=tuple(str(ll.lanelet_id) for ll in lanelets),
            position=None if position is None else (float(position[0]), float(position[1])),
            stop_lines=tuple(_stop_line(ll) for ll in lanelets)))
    return lights


def _last_step(root: etree._Element) -> int:
    """The last time step any obstacle of the file is seen at (each obstacle's last state:
    reading every state's time costs more than the rest of the map)."""
    found = root.xpath("dynamicObstacle/initialState/time/exact/text() | "
                       "dynamicObstacle/trajectory/state[last()]/time/exact/text()")
    texts = found if isinstance(found, list) else []
    return int(max((float(t) for t in texts if isinstance(t, str)), default=0.0))


def read_lanelet_map(path: Path) -> LaneletMap:
    """The lane network of a CommonRoad file; what ``commonroad-io`` raises on a malformed
    file passes through (the caller names the file)."""
    root = etree.parse(str(path)).getroot()
    dt = float(root.get("timeStepSize", "0.1"))
    last_step = _last_step(root)
    network = _network(root)
    phases = {}
    for light in network.traffic_lights:
        cycle = light.traffic_light_cycle
        active = light.active and cycle is not None and cycle.cycle_elements
        phases[str(light.traffic_light_id)] = light_phases(light, last_step, dt) if active else ()
    return LaneletMap(source=str(path),
                      strips=tuple(lane_strip(ll) for ll in network.lanelets),
                      lights=tuple(recorded_lights(network)), phases=phases, dt=dt)

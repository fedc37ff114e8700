"""A recording's lane network in the neutral model of ``roads.recorded_road``: CommonRoad
lanelets (read with ``commonroad-io``) become :class:`LaneStrip`\\ s, its traffic lights
:class:`RecordedLight`\\ s with their stop lines, their recorded cycles :class:`LightPhase`\\ s.
Only the map is read from a CommonRoad file (obstacles and planning problems are taken out of
the XML first, as the trajectory reader does).

highD has no lanelets: its lanes are straight, between the recording's lane markings
(``upperLaneMarkings``, ``lowerLaneMarkings``), as long as the stretch its vehicles drive. Its
strips are named by highD's ``laneId`` (upper carriageway 2, 3...; lower carriageway after a
gap of one), as its tracks name their lanes, in the reader's frame (the file's, y growing
downwards), so tracks and map line up.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork, LaneletType
from lxml import etree

from scenweave.mining.readers import commonroad, highd
from scenweave.mining.readers.commonroad import _network, _stop_line, light_phases
from scenweave.mining.tracks import LightPhase
from scenweave.roads.recorded_road import LaneStrip, RecordedLight

#: a highD lane reaches this far beyond the first and last vehicle position (m)
HIGHD_MARGIN_M = 10.0
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


def _straight(x_from: float, x_to: float, y: float) -> np.ndarray:
    return np.array([[x_from, y], [x_to, y]], dtype=float)


def highd_strips(upper: np.ndarray, lower: np.ndarray, x_min: float, x_max: float
                 ) -> list[LaneStrip]:
    """The straight lanes between highD's markings (sorted y, the file's frame): the upper
    carriageway drives towards -x, the lower towards +x; ids are highD's laneIds."""
    strips = []
    upper_ids = [str(i + 2) for i in range(len(upper) - 1)]
    for i, lane in enumerate(upper_ids):  # towards -x: left is -y, the smaller marking
        strips.append(LaneStrip(
            lane, _straight(x_max, x_min, upper[i]), _straight(x_max, x_min, upper[i + 1]),
            left_neighbour=upper_ids[i - 1] if i else None, left_same_direction=True,
            right_neighbour=upper_ids[i + 1] if i + 1 < len(upper_ids) else None,
            right_same_direction=True))
    lower_ids = [str(len(upper) + 2 + j) for j in range(len(lower) - 1)]
    for j, lane in enumerate(lower_ids):  # towards +x: left is +y, the larger marking
        strips.append(LaneStrip(
            lane, _straight(x_min, x_max, lower[j + 1]), _straight(x_min, x_max, lower[j]),
            left_neighbour=lower_ids[j + 1] if j + 1 < len(lower_ids) else None,
            left_same_direction=True, right_neighbour=lower_ids[j - 1] if j else None,
            right_same_direction=True))
    return strips


def read_highd_map(path: Path) -> LaneletMap:
    """The straight lanes of a highD recording (its ``NN_tracks.csv``)."""
    number = highd.TRACKS.match(path.name)
    if number is None:
        raise ValueError(f"{path.name}: a highD tracks file is named NN_tracks.csv")
    fps, upper, lower = highd._recording(path, number.group(1), [])
    tracks = highd.read(path).tracks
    if not tracks:
        raise ValueError(f"{path.name}: no vehicle says how long the road is")
    x_min = min(float(t.x.min()) - t.length_m for t in tracks) - HIGHD_MARGIN_M
    x_max = max(float(t.x.max()) + t.length_m for t in tracks) + HIGHD_MARGIN_M
    return LaneletMap(source=str(path), strips=tuple(highd_strips(upper, lower, x_min, x_max)),
                      lights=(), phases={}, dt=1.0 / fps)


def read_road_network(path: Path) -> LaneletMap:
    """The lane network of any file a trajectory reader takes that carries one: CommonRoad
    XML, highD; ``ValueError`` for another format."""
    path = Path(path)
    if highd.sniff(path):
        return read_highd_map(path)
    if commonroad.sniff(path):
        return read_lanelet_map(path)
    raise ValueError("no lane network in this format (CommonRoad XML and highD carry one)")


def companions(path: Path) -> list[Path]:
    """The files a recording's lane network is read from besides ``path`` (highD's
    recordingMeta), for a cache key."""
    number = highd.TRACKS.match(Path(path).name)
    if number is None:
        return []
    return [Path(path).with_name(f"{number.group(1)}_recordingMeta.csv")]

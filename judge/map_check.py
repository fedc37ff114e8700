"""The map check of a converted recorded road: do the lanelets' centre lines land on their own
road and lane of the OpenDRIVE map, as esmini's RoadManager reads it?

Each lanelet's centre line (midway between its borders) is sampled every
:data:`SAMPLE_STEP_M` (at 1, 3, 5... m, so no sample sits on the seam between two lanelets),
with its heading, and located by esmini (``player.road_manager``). A sample counts as on its
own road and lane when esmini puts it there, or when esmini picked another road overlapping
there (lanelets overlap inside junctions and esmini keeps the first road it finds, whatever
the heading) while the sample lies inside its own lane (closer to its centre than half the
lanelet's width). The *strict* share counts only the first case. The error is the distance
from the sample to its own lane's centre line in the map (as esmini places lane positions).
"""

from __future__ import annotations

import importlib
import importlib.util
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenweave.player.road_manager import ANY_DRIVING, NO_ROAD, MapProbe, PointGroup, probe_map
from scenweave.roads.recorded_geometry import Floats, Mask
from scenweave.roads.recorded_road import LaneStrip

SAMPLE_STEP_M = 2.0
#: a sample within this of its lane's centre is placed well (m)
CLOSE_M = 0.5


@dataclass(frozen=True)
class CentreSamples:
    """One lanelet's centre line samples: points, headings and the lanelet's width there."""

    strip: str
    xy: Floats
    heading: Floats
    width: Floats


@dataclass(frozen=True)
class MapCheck:
    """The map check's numbers for one map (shares in [0, 1], errors in m)."""

    loaded: bool
    problem: str = ""
    samples: int = 0
    own_lane: float = 0.0
    own_lane_strict: float = 0.0
    within_close: float = 0.0
    error_p50: float = float("nan")
    error_p95: float = float("nan")
    error_max: float = float("nan")
    #: the lanelets with samples off their own lane or further than CLOSE_M: (id, count)
    misplaced: tuple[tuple[str, int], ...] = field(default_factory=tuple)
    #: per sample: error (m), on its own road and lane, strictly so (for pooling checks)
    errors: Floats = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)
    own: Mask = field(default_factory=lambda: np.zeros(0, bool), repr=False, compare=False)
    strict: Mask = field(default_factory=lambda: np.zeros(0, bool), repr=False, compare=False)

    def line(self) -> str:
        """The check as one line of text."""
        if not self.loaded:
            return f"esmini does not load the map: {self.problem}"
        return (f"{self.samples} samples: own road and lane {100 * self.own_lane:.1f} % "
                f"(strict {100 * self.own_lane_strict:.1f} %), within {CLOSE_M} m "
                f"{100 * self.within_close:.1f} %, error p50/p95/max {self.error_p50:.2f}/"
                f"{self.error_p95:.2f}/{self.error_max:.2f} m")


def _at(polyline: Floats, along: Floats, where: Floats) -> Floats:
    return np.column_stack([np.interp(where, along, polyline[:, 0]),
                            np.interp(where, along, polyline[:, 1])])


def centre_samples(strip: LaneStrip, step: float = SAMPLE_STEP_M) -> CentreSamples:
    """The lanelet's centre line every ``step`` metres (its middle, if shorter)."""
    n = max(len(strip.left), len(strip.right))
    centre = strip.centre
    left, right = _resampled(strip.left, n), _resampled(strip.right, n)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(centre, axis=0).T))])
    length = float(along[-1])
    where = np.arange(step / 2, length, step) if length > step else np.array([length / 2])
    xy = _at(centre, along, where)
    ahead = _at(centre, along, np.minimum(where + 0.5, length))
    behind = _at(centre, along, np.maximum(where - 0.5, 0.0))
    heading = np.arctan2(ahead[:, 1] - behind[:, 1], ahead[:, 0] - behind[:, 0])
    width = np.hypot(*(_at(left, along, where) - _at(right, along, where)).T)
    return CentreSamples(strip.id, xy, heading, width)


def _resampled(polyline: Floats, n: int) -> Floats:
    points = np.asarray(polyline, dtype=float)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    return _at(points, along, np.linspace(0.0, along[-1], n))


def distance_to_polyline(points: Floats, line: Floats) -> Floats:
    """Each point's distance to the nearest point of a polyline (inf for an empty one)."""
    if len(line) == 0:
        return np.full(len(points), np.inf)
    if len(line) == 1:
        along: Floats = np.hypot(*(points - line[0]).T)
        return along
    a, seg = line[:-1], np.diff(line, axis=0)
    rel = points[:, None, :] - a[None]
    u = np.clip((rel * seg[None]).sum(2) / np.maximum((seg ** 2).sum(1), 1e-12)[None], 0, 1)
    gap = rel - u[..., None] * seg[None]
    nearest: Floats = np.sqrt((gap ** 2).sum(2).min(axis=1))
    return nearest


def judged(probe: MapProbe, samples: Sequence[CentreSamples],
           lanes: Mapping[str, tuple[int, int]]) -> MapCheck:
    """The check's numbers from esmini's answers."""
    if not probe.loaded:
        return MapCheck(loaded=False, problem=probe.problem)
    own, strict, errors, misplaced = [], [], [], []
    for sample, probed, line in zip(samples, probe.groups, probe.centres, strict=True):
        road, lane = lanes[sample.strip]
        error = distance_to_polyline(sample.xy, np.asarray(line, dtype=float).reshape(-1, 2))
        exact = np.array([p.road_id == road and p.lane_id == lane for p in probed])
        inside = np.array([p.own_road_lane_id == lane for p in probed]) & \
            (error < sample.width / 2)
        on = exact | inside
        own.append(on)
        strict.append(exact)
        errors.append(error)
        bad = int((~on | (error > CLOSE_M)).sum())
        if bad:
            misplaced.append((sample.strip, bad))
    return _summary(np.concatenate(errors) if errors else np.zeros(0),
                    np.concatenate(own) if own else np.zeros(0, bool),
                    np.concatenate(strict) if strict else np.zeros(0, bool),
                    tuple(sorted(misplaced, key=lambda m: -m[1])))


def _summary(errors: Floats, own: Mask, strict: Mask,
             misplaced: tuple[tuple[str, int], ...] = ()) -> MapCheck:
    if not len(errors):
        return MapCheck(loaded=True)
    return MapCheck(loaded=True, samples=len(errors), own_lane=float(own.mean()),
                    own_lane_strict=float(strict.mean()),
                    within_close=float((errors <= CLOSE_M).mean()),
                    error_p50=float(np.percentile(errors, 50)),
                    error_p95=float(np.percentile(errors, 95)),
                    error_max=float(errors.max()), misplaced=misplaced,
                    errors=errors, own=own, strict=strict)


def pooled(checks: Sequence[MapCheck]) -> MapCheck:
    """One check over the samples of several maps (a map that did not load counts as not
    loaded, with the first such map's reason)."""
    broken = [c for c in checks if not c.loaded]
    if broken:
        return MapCheck(loaded=False, problem=broken[0].problem)
    return _summary(np.concatenate([c.errors for c in checks] or [np.zeros(0)]),
                    np.concatenate([c.own for c in checks] or [np.zeros(0, bool)]),
                    np.concatenate([c.strict for c in checks] or [np.zeros(0, bool)]),
                    tuple(m for c in checks for m in c.misplaced))


def _triples(samples: CentreSamples, last: int | None = None
             ) -> list[tuple[float, float, float]]:
    rows = range(len(samples.xy)) if last is None else range(len(samples.xy))[-last:]
    return [(float(samples.xy[k, 0]), float(samples.xy[k, 1]), float(samples.heading[k]))
            for k in rows]


def _lead_in(strip: LaneStrip, samples: Mapping[str, CentreSamples]
             ) -> list[tuple[float, float, float]]:
    """The last samples of the lanelet's first predecessor: a car reaches the lanelet from
    there, and esmini's position object keeps to the road it is on where roads overlap."""
    before = next((samples[p] for p in strip.predecessors if p in samples), None)
    return [] if before is None else _triples(before, last=2)


def check_map(xodr: Path, strips: Sequence[LaneStrip],
              lanes: Mapping[str, tuple[int, int]], library: Path | None = None) -> MapCheck:
    """Sample every lanelet's centre line, locate the samples with esmini on ``xodr`` (in a
    child process), and judge: see the module docstring."""
    kept = [s for s in strips if s.id in lanes]
    samples = [centre_samples(s) for s in kept]
    by_id = {s.strip: s for s in samples}
    groups = [PointGroup(*lanes[s.strip], _triples(s), _lead_in(strip, by_id))
              for strip, s in zip(kept, samples, strict=True)]
    return judged(probe_map(xodr, groups, library=library), samples, lanes)


@dataclass(frozen=True)
class PositionsCheck:
    """Where recorded vehicle positions land on the map, as esmini locates them."""

    loaded: bool
    positions: int = 0
    #: share of positions on a lane a car drives on (inside the road, esmini's lane type)
    on_driving_lane: float = 0.0
    problem: str = ""


def positions_on_driving_lanes(xodr: Path, tracks: Sequence[Floats],
                               library: Path | None = None) -> PositionsCheck:
    """Locate each of the tracks' positions (rows ``x, y, heading``) on its own, and count
    those on a driving lane. On its own: a position object that follows a car keeps to its
    road while the car is within 2 m of that road's edge (esmini's tracking), which would
    count a car crossing into an overlapping lanelet as off the lanes."""
    groups = [PointGroup(NO_ROAD, 0, [(float(x), float(y), float(h))])
              for track in tracks for x, y, h in track]
    probe = probe_map(xodr, groups, library=library)
    if not probe.loaded:
        return PositionsCheck(False, problem=probe.problem)
    types = [p.in_lane_type for group in probe.groups for p in group]
    on = sum(1 for t in types if t & ANY_DRIVING)
    return PositionsCheck(True, len(types), on / len(types) if types else 0.0)


@dataclass(frozen=True)
class CarlaMapCheck:
    """What CARLA's own OpenDRIVE parser (``carla.Map``, no server needed) makes of a map."""

    waypoints: int
    nan_waypoints: int
    #: share of the lanelet centre samples CARLA's nearest driving waypoint puts on their own
    #: road and lane
    own_lane: float

    def line(self) -> str:
        return (f"CARLA: {self.waypoints} waypoints, {self.nan_waypoints} NaN, centre samples "
                f"on their own road and lane {100 * self.own_lane:.1f} %")


def carla_map_check(xodr_text: str, strips: Sequence[LaneStrip],
                    lanes: Mapping[str, tuple[int, int]], name: str = "recorded"
                    ) -> CarlaMapCheck | None:
    """Parse the map with the ``carla`` client package and ask where the centre samples lie
    (CARLA's frame flips y); ``None`` where the package is not installed."""
    if importlib.util.find_spec("carla") is None:
        return None
    carla = importlib.import_module("carla")
    world_map = carla.Map(name, xodr_text)
    waypoints = world_map.generate_waypoints(2.0)
    nan = sum(1 for w in waypoints if not all(math.isfinite(v) for v in (
        w.transform.location.x, w.transform.location.y, w.transform.rotation.yaw)))
    hits, total = 0, 0
    for strip in strips:
        if strip.id not in lanes:
            continue
        for x, y in centre_samples(strip).xy:
            found = world_map.get_waypoint(carla.Location(x=float(x), y=-float(y), z=0.0),
                                           project_to_road=True)
            total += 1
            hits += found is not None and (found.road_id, found.lane_id) == lanes[strip.id]
    return CarlaMapCheck(len(waypoints), nan, hits / total if total else 0.0)

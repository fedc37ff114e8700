"""What a trajectory reader yields: :class:`Recording`, a road's worth of :class:`Track`\\ s.

Every reader (CommonRoad XML, NGSIM CSV, highD CSVs) turns its format into this one model, so
manoeuvre detection never sees a file format. Units are SI; times in seconds from the
recording's start; ``s`` runs along the road in the direction of travel (a car driving on
has a growing ``s``), so gaps are differences in ``s`` between two cars of one lane.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

#: numbers, one per step of a track (times, positions, speeds; NaN where unknown)
Floats = npt.NDArray[np.float64]
#: yes or no, one per step of a track
Mask = npt.NDArray[np.bool_]
#: step (row) numbers
Steps = npt.NDArray[np.intp]


@dataclass(frozen=True)
class Track:
    """One vehicle over the steps it was seen."""

    #: the vehicle's id in its file (unique within the recording)
    id: str
    #: bounding box (m)
    length_m: float
    width_m: float
    #: "car", "truck", "van", "motorcycle" (the CARLA blueprint families ScenWeave knows)
    vehicle_type: str
    #: per step: time (s), position in the file's frame (m), heading (rad), speed (m/s)
    t: Floats
    x: Floats
    y: Floats
    heading: Floats
    speed: Floats
    #: per step: position along the road in the direction of travel (m)
    s: Floats
    #: per step: the lane, as the file names it (a lane index or a lanelet id), as strings
    lane: np.ndarray
    #: per step: the lane's index counted from the road's left edge in the direction of
    #: travel (1 = leftmost); a higher index is further right. NaN where unknown.
    lane_index: Floats = field(default_factory=lambda: np.empty(0))
    #: per step: the frame ``s`` is measured in (urban maps: a direction group); two cars'
    #: ``s`` compare only where their frames are equal. Empty: one frame for the recording.
    road: np.ndarray = field(default_factory=lambda: np.empty(0))
    #: per step: lateral position across the road (m, + to the left), where the reader knows
    #: it better than the positions tell (a replay's lane and lane offset); else empty
    lateral: Floats = field(default_factory=lambda: np.empty(0))

    def __post_init__(self) -> None:
        n = len(self.t)
        for name in ("x", "y", "heading", "speed", "s", "lane"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"track {self.id}: {name} has {len(getattr(self, name))} "
                                 f"values for {n} steps")
        if len(self.road) not in (0, n):
            raise ValueError(f"track {self.id}: road has {len(self.road)} values for {n} steps")
        if len(self.lane_index) not in (0, n):
            raise ValueError(f"track {self.id}: lane_index has {len(self.lane_index)} values "
                             f"for {n} steps")

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self.t) else 0.0


@dataclass(frozen=True)
class LightPhase:
    """A traffic light's state from ``start_s`` to ``end_s``."""

    start_s: float
    end_s: float
    state: str  # "green", "yellow", "red"


@dataclass(frozen=True)
class TrafficLight:
    """A traffic light: where its stop line is along the road of the lanes it controls, and
    its phases over the recording."""

    id: str
    lanes: tuple[str, ...]
    stop_line_s: float | None
    phases: tuple[LightPhase, ...]
    #: the movements it controls, as CommonRoad names them ("all", "left", "straightRight"...)
    direction: str = "all"
    #: per controlled lane: (lane, x0, y0, x1, y1) of its stop line in the file's frame, from
    #: the left end to the right end as seen driving the lane
    stop_lines: tuple[tuple[str, float, float, float, float], ...] = ()


@dataclass
class Recording:
    """One file's (or one recording's) tracks, with where they came from."""

    source: str
    #: the time step of the recording (s)
    dt: float
    tracks: list[Track]
    lights: list[TrafficLight] = field(default_factory=list)
    #: the format's name ("commonroad", "ngsim-csv", "highd")
    reader: str = ""
    #: what the reader could not take and why (one line each)
    warnings: list[str] = field(default_factory=list)
    #: lanes inside junctions (where roads cross), as ``Track.lane`` names them
    junction_lanes: frozenset[str] = frozenset()
    #: vehicles the file took out but whose path it implies (CommonRoad's planning-problem
    #: ego): they are never mined, but nobody's lead or follower is found past them
    removed: list[Track] = field(default_factory=list)

"""What happened when a scenario was played: every entity's state per step, and the events.

A ``Playback`` is plain data (lists of numbers), written next to the scenario as
``replay.json`` and read back by the checks and the pictures. Positions are esmini's: world
x, y, z and heading h in the OpenSCENARIO frame (= OpenDRIVE's), the road position
(road, lane, s, lane offset) of the entity's reference point, the bounding box
(length, width and the box centre's offset ahead of the reference point).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

#: recorded per entity and step (esmini's SE_ScenarioObjectState names in brackets)
TRACK_FIELDS = ("x", "y", "z", "h", "speed", "road", "lane", "s", "lane_offset", "junction")
_STATE_FIELDS = {"x": "x", "y": "y", "z": "z", "h": "h", "speed": "speed", "road": "roadId",
                 "lane": "laneId", "s": "s", "lane_offset": "laneOffset", "junction": "junctionId"}
NO_JUNCTION = 0xFFFFFFFF


class EntityState(Protocol):
    """What a playback records of an entity at a step: esmini's ``SE_ScenarioObjectState``
    (``engine.ObjectState``) by its field names."""

    x: float
    y: float
    z: float
    h: float
    speed: float
    roadId: int
    laneId: int
    s: float
    laneOffset: float
    junctionId: int
    length: float
    width: float
    centerOffsetX: float


@dataclass(frozen=True)
class StoryboardChange:
    """A storyboard element (event, action, ...) changed state at ``time_s``."""

    time_s: float
    name: str
    kind: str
    state: str

    def to_list(self) -> list[float | str]:
        return [self.time_s, self.name, self.kind, self.state]


@dataclass(frozen=True)
class Box:
    """An entity's bounding box: length, width and how far its centre lies ahead of the
    reference point (esmini's centerOffsetX)."""

    length: float
    width: float
    center_ahead: float


@dataclass
class Playback:
    """One replay: sample times, per-entity tracks, collisions, storyboard changes, esmini's log.

    ``engine_error`` is set when esmini could not play the scenario (it crashed, aborted, hung
    or refused the file); the tracks then hold what was recorded before, possibly nothing.
    """

    times: list[float] = field(default_factory=list)
    tracks: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    boxes: dict[str, Box] = field(default_factory=dict)
    collisions: list[tuple[float, str, str]] = field(default_factory=list)
    storyboard: list[StoryboardChange] = field(default_factory=list)
    #: light action name -> the colour it sets (from the translation, CARLA's names)
    lights: dict[str, str] = field(default_factory=dict)
    #: light action name -> where its signal stands (x, y, OpenDRIVE frame), for the viewer
    light_positions: dict[str, list[float]] = field(default_factory=dict)
    #: the map file the scenario was played on (its path as given)
    map: str | None = None
    engine_error: str | None = None
    quit_by_engine: bool = False
    log: list[str] = field(default_factory=list)
    timings_s: dict[str, float] = field(default_factory=dict)
    #: the judge's comparison with a record's series (``judge.replay``): per "<entity>
    #: <quantity>", the max and RMS error over the recorded samples; empty without series
    series_errors: dict[str, dict[str, float]] = field(default_factory=dict)

    @classmethod
    def empty(cls, names: Iterable[str]) -> Playback:
        return cls(tracks={name: {f: [] for f in TRACK_FIELDS} for name in names})

    # --- recording (in the engine's child process) ---------------------------------------
    def add_state(self, name: str, state: EntityState) -> None:
        track = self.tracks[name]
        for key, attr in _STATE_FIELDS.items():
            value = getattr(state, attr)
            if key == "junction":
                value = -1 if value == NO_JUNCTION else int(value)
            elif key in ("road", "lane"):
                value = int(value)
            else:
                value = round(float(value), 4)
            track[key].append(value)
        if name not in self.boxes:
            self.boxes[name] = Box(round(state.length, 4), round(state.width, 4),
                                   round(state.centerOffsetX, 4))

    def add_collision(self, time_s: float, a: str, b: str) -> None:
        first, second = sorted((a, b))
        if not any(c == (time_s, first, second) for c in self.collisions):
            self.collisions.append((time_s, first, second))

    # --- reading ---------------------------------------------------------------------------
    @property
    def entities(self) -> list[str]:
        return list(self.tracks)

    def index_at(self, time_s: float) -> int:
        """The index of the last sample at or before ``time_s`` (0 before the first)."""
        best = 0
        for i, t in enumerate(self.times):
            if t <= time_s + 1e-9:
                best = i
            else:
                break
        return best

    def value(self, entity: str, key: str, time_s: float) -> float:
        """``key`` of ``entity`` at ``time_s``, linearly interpolated between samples."""
        series = self.tracks[entity][key]
        i = self.index_at(time_s)
        if i + 1 >= len(self.times) or key in ("road", "lane", "junction"):
            return series[i]
        t0, t1 = self.times[i], self.times[i + 1]
        w = 0.0 if t1 == t0 else min(max((time_s - t0) / (t1 - t0), 0.0), 1.0)
        return series[i] + (series[i + 1] - series[i]) * w

    def distance(self, a: str, b: str, index: int) -> float:
        """Straight-line distance between the reference points of ``a`` and ``b``."""
        ta, tb = self.tracks[a], self.tracks[b]
        return math.hypot(ta["x"][index] - tb["x"][index], ta["y"][index] - tb["y"][index])

    def fired(self, kind: str = "event") -> dict[str, float]:
        """Each storyboard element of ``kind`` that started running, and when (first time)."""
        started: dict[str, float] = {}
        for change in self.storyboard:
            if change.kind == kind and change.state == "running":
                started.setdefault(change.name, change.time_s)
        return started

    @property
    def duration_s(self) -> float:
        return self.times[-1] if self.times else 0.0

    # --- files -----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "times": self.times, "tracks": self.tracks,
            "boxes": {k: [b.length, b.width, b.center_ahead] for k, b in self.boxes.items()},
            "collisions": [list(c) for c in self.collisions],
            "storyboard": [c.to_list() for c in self.storyboard],
            "lights": self.lights, "light_positions": self.light_positions, "map": self.map,
            "engine_error": self.engine_error, "quit_by_engine": self.quit_by_engine,
            "log": self.log, "timings_s": self.timings_s, "series_errors": self.series_errors,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Playback:
        return cls(
            times=list(data.get("times", [])), tracks=dict(data.get("tracks", {})),
            boxes={k: Box(*v) for k, v in data.get("boxes", {}).items()},
            collisions=[tuple(c) for c in data.get("collisions", [])],
            storyboard=[StoryboardChange(*c) for c in data.get("storyboard", [])],
            lights=dict(data.get("lights", {})),
            light_positions=dict(data.get("light_positions", {})), map=data.get("map"),
            engine_error=data.get("engine_error"), quit_by_engine=data.get("quit_by_engine", False),
            log=list(data.get("log", [])), timings_s=dict(data.get("timings_s", {})),
            series_errors=dict(data.get("series_errors", {})),
        )

    def write(self, path: Path) -> None:
        path.write_text(json.dumps(self.to_dict(), separators=(",", ":")), encoding="utf-8")

    @classmethod
    def read(cls, path: Path) -> Playback:
        return cls.from_dict(json.loads(path.read_text(encoding="utf-8")))

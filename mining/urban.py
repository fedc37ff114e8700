"""Urban events: what a car does at a traffic light's stop line, and in-lane driving between
junctions. Geometry, not ``s``: a stop line is a segment in the file's frame, a car's front
crosses it or stops before it, and how far a car drove is the length of its path (which never
jumps where lanelets of other directions meet).

| class | found when |
|---|---|
| U4_3 | the front crosses its lane's stop line on green and the car goes straight on |
| U4_4 | ... on green and turns right |
| U4_2 | ... on yellow (orange), straight on or right |
| U4_1 | the car, arriving faster than ``approach_from_ms``, comes to rest with its front
  between ``stop_past_line_m`` past and ``stop_before_line_m`` before the line while its
  light is red or yellow; first in line, else refused (``Event.refused``) naming its place |
| U1_1 | at least ``in_lane_min_s`` on lanes outside junctions and light approaches, moving,
  turning less than ``in_lane_max_turn_deg``, no lane change (of its lane index, nor a
  crossing of the line: ``mining.highway.lane_changes``) |

Thresholds: ``mining/thresholds.json`` section ``urban``. Each event becomes an ADScene object
(``mining.lights.adscene_of`` documents the fields) that ingest's canonicaliser turns into
the record.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from scipy.signal import savgol_filter

from scenweave.mining.highway import lane_changes
from scenweave.mining.lanes import lane_movement
from scenweave.mining.lights import CODE_OF_STATE, adscene_header, frame_of, state_at
from scenweave.mining.motion import PositionsSpeed, positions_speed, runs
from scenweave.mining.scene import Event, Scene
from scenweave.mining.tracks import Floats, Mask, TrafficLight

#: a movement's heading change (deg): right below -RIGHT_DEG, straight within STRAIGHT_DEG
RIGHT_DEG, STRAIGHT_DEG = 30.0, 20.0
#: the movement is judged over this much path past the line (or to the track's end)
MOVEMENT_PATH_M = 30.0
#: a car that drove this far past the line has shown its movement (a turn has turned by
#: more than a straight car's limit), for the movement of its lane
SHOWN_MOVEMENT_M = 10.0
AFTER_STOP_S = 3.0
HISTORY_S = 15.0
#: a stop line is found within this of a car's front sideways (beyond its half length)
LINE_SIDE_M = 1.0
#: (the light's colour, the movement) -> the class of a car crossing the stop line
PASS_CODES = {("green", "straight"): "U4_3", ("green", "right"): "U4_4",
              ("yellow", "straight"): "U4_2", ("yellow", "right"): "U4_2"}


@dataclass(frozen=True)
class StopLine:
    """One lane's stop line of one light: its middle, its half length, the lane's direction."""

    light: TrafficLight
    lane: str
    middle: Floats
    half_m: float
    along: Floats

    def ahead_m(self, x: Floats, y: Floats) -> Floats:
        """How far the line is ahead of points (m, negative once past)."""
        return (self.middle[0] - x) * self.along[0] + (self.middle[1] - y) * self.along[1]

    def beside_m(self, x: Floats, y: Floats) -> Floats:
        return np.abs(-(x - self.middle[0]) * self.along[1] + (y - self.middle[1]) * self.along[0])


def stop_lines(scene: Scene) -> list[StopLine]:
    found = []
    for light in scene.recording.lights:
        for lane, x0, y0, x1, y1 in light.stop_lines:
            a, b = np.array([x0, y0]), np.array([x1, y1])
            across = b - a
            length = float(np.hypot(*across))
            if length <= 0:
                continue
            along = np.array([-across[1], across[0]]) / length  # the line runs left to right
            found.append(StopLine(light, lane, (a + b) / 2, length / 2, along))
    return found


def urban_events(scene: Scene) -> Iterator[Event]:
    """Every urban event of the recording."""
    if not scene.recording.lights and not scene.recording.junction_lanes:
        return
    lines = stop_lines(scene)
    paths = [path_length(scene, i) for i in range(len(scene.tracks))]
    speeds = [path_speed(scene, i, paths[i]) for i in range(len(scene.tracks))]
    changing = [(c.track, c.start_s, c.end_s) for c in lane_changes(scene)]
    urban = UrbanScene(scene, lines, paths, speeds, changing)
    mapped = bool(lines or scene.recording.junction_lanes)  # where junctions are is known
    for i in range(len(scene.tracks)):
        yield from urban.light_events(i)
        if mapped:
            yield from urban.in_lane(i)


def path_length(scene: Scene, i: int) -> Floats:
    track = scene.tracks[i]
    steps = np.hypot(np.diff(track.x), np.diff(track.y))
    return np.concatenate([[0.0], np.cumsum(steps)])


def path_speed(scene: Scene, i: int, path: Floats) -> Floats:
    """Speed along the path, smoothed as ``mining.motion`` smooths ``s``."""
    track = scene.tracks[i]
    dt = scene.recording.dt
    points = int(round(scene.thresholds["smoothing"]["window_s"] / dt)) | 1
    if len(path) < max(points, 5):
        return np.asarray(track.speed, dtype=float)
    return np.clip(savgol_filter(path, points, 2, deriv=1, delta=dt, mode="interp"), 0, None)


@dataclass
class UrbanScene:
    """A scene with its stop lines and each track's path length and speed along it."""

    scene: Scene
    lines: list[StopLine]
    paths: list[Floats]
    speeds: list[Floats]
    #: (track, start, end) of each lane change (``mining.highway.lane_changes``): no in-lane
    #: stretch runs across one
    changing: list[tuple[int, float, float]] = field(default_factory=list)

    @property
    def limits(self) -> dict[str, float]:
        return self.scene.thresholds["urban"]

    def measured(self, i: int) -> PositionsSpeed:
        """Track ``i``'s speed along its path from its positions, with its tracking noise
        (``mining.motion.positions_speed``): what its record gives."""
        track = self.scene.tracks[i]
        return positions_speed(track.t, self.paths[i], track.speed)

    def record_speeds(self, i: int) -> Floats:
        """The speeds a record gives: from the positions, at tracking noise the nearest
        sample's that is not (``PositionsSpeed.filled``)."""
        return self.measured(i).filled

    def front(self, i: int) -> tuple[Floats, Floats]:
        track = self.scene.tracks[i]
        half = track.length_m / 2
        return track.x + half * np.cos(track.heading), track.y + half * np.sin(track.heading)

    def lines_of(self, i: int) -> list[StopLine]:
        """The stop line of each lane the car drove in, once (several lights, for different
        movements, may share a lane: :meth:`light_for` picks the one that counts)."""
        lanes = set(self.scene.tracks[i].lane.astype(str))
        return list({line.lane: line for line in reversed(self.lines)
                     if line.lane in lanes}.values())

    # --- at the light ----------------------------------------------------------------------

    def crossings(self, i: int, line: StopLine) -> tuple[Floats, Mask, list[int]]:
        """How far ``line`` is ahead of track ``i``'s front per step, where the front is
        beside it, and the step (at most one) before it crosses it in the line's lane."""
        track = self.scene.tracks[i]
        fx, fy = self.front(i)
        ahead, beside = line.ahead_m(fx, fy), line.beside_m(fx, fy)
        near = beside <= line.half_m + LINE_SIDE_M
        steps = np.flatnonzero(near[:-1] & (ahead[:-1] > 0) & (ahead[1:] <= 0)
                               & (track.lane[:-1] == line.lane))
        return ahead, near, steps[:1].tolist()

    @cached_property
    def driven_from(self) -> dict[str, str]:
        """Each stop line's lane -> the one movement every car recorded crossing it and
        driving on :data:`SHOWN_MOVEMENT_M` took (two cars at least): a turning lane's own
        arrow is the light for a car that stands in it (issue 32)."""
        seen: dict[str, set[str]] = {}
        counts: dict[str, int] = {}
        for i in range(len(self.scene.tracks)):
            for line in self.lines_of(i):
                for k in self.crossings(i, line)[2]:
                    if self.paths[i][-1] - self.paths[i][k + 1] >= SHOWN_MOVEMENT_M:
                        seen.setdefault(line.lane, set()).add(self.movement(i, k + 1))
                        counts[line.lane] = counts.get(line.lane, 0) + 1
        return {lane: moves.pop() for lane, moves in seen.items()
                if len(moves) == 1 and counts[lane] >= 2}

    def light_events(self, i: int) -> Iterator[Event]:
        crossed_at: set[int] = set()
        for line in self.lines_of(i):
            ahead, near, steps = self.crossings(i, line)
            for k in steps:
                if k + 1 not in crossed_at:
                    crossed_at.add(k + 1)
                    event = self._crossing(i, line, k + 1, ahead)
                    if event is not None:
                        yield event
            event = self._stop(i, line, ahead, near)
            if event is not None:
                yield event

    def _crossing(self, i: int, line: StopLine, k: int, ahead: Floats) -> Event | None:
        track, path = self.scene.tracks[i], self.paths[i]
        if ahead[k:].min() > -self.limits["stop_past_line_m"] \
                and self.speeds[i][-1] < self.limits["stopped_below_ms"]:
            return None  # it came to rest within the stop line's tolerance: no pass
        move = self.movement(i, k)
        light = self.light_for(line, move)
        colour = None if light is None else state_at(light, float(track.t[k]))
        if colour is None:
            return None
        code = PASS_CODES.get((colour, move))
        if code is None:
            return None
        before = np.flatnonzero(ahead[:k] >= self.limits["approach_from_m"])
        first = int(before[-1]) if len(before) else 0
        if ahead[first] < self.limits["min_approach_m"]:
            return None
        beyond = np.flatnonzero(path >= path[k] + self.limits["after_pass_m"])
        last = int(beyond[0]) if len(beyond) else len(track.t) - 1
        return self._event(code, i, first, last, (float(ahead[first]), colour))

    def movement(self, i: int, k: int) -> str:
        """``straight``, ``right`` or ``left`` from the heading change over the path from a
        second before step ``k`` to ``MOVEMENT_PATH_M`` past it (or the track's end)."""
        track, path = self.scene.tracks[i], self.paths[i]
        start = int(np.searchsorted(track.t, track.t[k] - 1.0))
        end = min(int(np.searchsorted(path, path[k] + MOVEMENT_PATH_M)), len(path) - 1)
        heading = np.degrees(np.unwrap(track.heading[start:end + 1]))
        turned = float(heading[-1] - heading[0]) if len(heading) > 1 else 0.0
        if abs(turned) <= STRAIGHT_DEG:
            return "straight"
        if turned <= -RIGHT_DEG:
            return "right"
        return "left" if turned >= RIGHT_DEG else "unclear"

    def stop_movement(self, i: int, k: int, line: StopLine) -> str:
        """The movement a car standing at ``line`` from step ``k`` waits for: its own path
        where it drives on far enough to show it, else its lane's (the one every recorded
        car took from it, or the map's: a left-turn lane waits for its own arrow, whatever
        the straight light shows), else straight on."""
        path = self.paths[i]
        if path[-1] - path[k] >= MOVEMENT_PATH_M:
            return self.movement(i, k)
        return self.driven_from.get(line.lane) or lane_movement(self.scene.strips, line.lane) \
            or (self.movement(i, k) if k + 1 < len(path) else "straight")

    def light_for(self, line: StopLine, move: str) -> TrafficLight | None:
        """The light of the line's lane that controls the movement (a light for ``all``
        where none names it)."""
        lights = [ln.light for ln in self.lines if ln.lane == line.lane]
        named = [lt for lt in lights if move in lt.direction.lower()]
        chosen = named or [lt for lt in lights if lt.direction.lower() == "all"]
        return chosen[0] if chosen else None

    def _stop(self, i: int, line: StopLine, ahead: Floats, near: Mask
              ) -> Event | None:
        limits, track, speed = self.limits, self.scene.tracks[i], self.speeds[i]
        reach = max(limits["stop_before_line_m"], limits["queue_within_m"])
        at_line = near & (ahead >= -limits["stop_past_line_m"]) & (ahead <= reach) \
            & (speed < limits["stopped_below_ms"])
        for k in np.flatnonzero(at_line)[:1].tolist():
            t = float(track.t[k])
            first = int(np.searchsorted(track.t, t - HISTORY_S))
            light = self.light_for(line, self.stop_movement(i, k, line))
            if light is None or state_at(light, t) not in ("red", "yellow"):
                return None
            if speed[first:k + 1].max() < limits["approach_from_ms"]:
                return None
            last = int(np.searchsorted(track.t, t + AFTER_STOP_S, side="right")) - 1
            event = self._event("U4_1", i, first, last, (float(ahead[first]), "red"))
            queue = self.queue_ahead(i, k, line, float(ahead[k]))
            if not queue and ahead[k] > limits["stop_before_line_m"]:
                return None  # at rest far from the line with nobody ahead: not for the light
            if queue:
                return replace(event, refused=(
                    f"stops {len(queue) + 1}. in line, behind {queue[-1]}, its front "
                    f"{ahead[k]:.1f} m before the stop line: a U4_1 scenario stops the ego "
                    "at the line, so only the first car's stop plays back"))
            return event
        return None

    def queue_ahead(self, i: int, k: int, line: StopLine, ahead_m: float) -> list[str]:
        """The cars between this car's front and the stop line in its lane (their centres),
        the one directly ahead of it last: empty when it is first in line."""
        t = self.scene.tracks[i].t[k]
        found = []
        for j, other in enumerate(self.scene.tracks):
            step = self.scene.step_at(j, float(t)) if j != i else None
            if step is None:
                continue
            x, y = np.array([other.x[step]]), np.array([other.y[step]])
            to_line = float(line.ahead_m(x, y)[0])
            if 0 < to_line < ahead_m + other.length_m / 2 \
                    and float(line.beside_m(x, y)[0]) <= line.half_m + LINE_SIDE_M:
                found.append((to_line, other.id))
        return [track_id for _, track_id in sorted(found)]

    # --- between junctions -----------------------------------------------------------------

    def in_lane(self, i: int) -> Iterator[Event]:
        limits, track, speed = self.limits, self.scene.tracks[i], self.speeds[i]
        lit = {lane for light in self.scene.recording.lights for lane in light.lanes}
        lanes = track.lane.astype(str)
        free = ~np.isin(lanes, [*self.scene.recording.junction_lanes, *lit, ""]) \
            & (speed >= limits["in_lane_min_speed_ms"])
        for _, start, end in (c for c in self.changing if c[0] == i):
            free &= (track.t < start - 1e-6) | (track.t > end + 1e-6)
        for first, last in runs(free):
            if track.t[last] - track.t[first] < limits["in_lane_min_s"] - 1e-6:
                continue
            last = min(last, int(np.searchsorted(track.t, track.t[first]
                                                 + limits["in_lane_max_s"], side="right")) - 1)
            heading = np.degrees(np.unwrap(track.heading[first:last + 1]))
            index = track.lane_index[first:last + 1] if len(track.lane_index) else np.zeros(1)
            if np.ptp(heading) > limits["in_lane_max_turn_deg"] \
                    or len(np.unique(index[np.isfinite(index)])) > 1:
                continue
            yield self._event("U1_1", i, first, last, None)

    # --- records ---------------------------------------------------------------------------

    def _event(self, code: str, i: int, first: int, last: int,
               seen: tuple[float, str] | None) -> Event:
        """The event's record; ``seen``: how far the stop line was ahead of the car's front at
        ``first`` (m) and the colour its light showed (``None``: no light)."""
        track = self.scene.tracks[i]
        start, end = float(track.t[first]), float(track.t[last])
        light = None if seen is None else (seen[0] + track.length_m / 2, seen[1])
        adscene = self.adscene(code, i, first, last, light)
        series = self.scene.series({"ego": i}, i, start, end)
        measured = self.measured(i)
        for key, values in (("ego_speed_ms", measured.fitted), ("ego_speed_raw_ms", measured.speed),
                            ("ego_noise", measured.noise.astype(float))):
            series[key] = [None if not np.isfinite(v) else round(float(v), 3)
                           for v in values[first:last + 1]]
        return Event(code, track.id, None, round(start, 3), round(end, 3), {}, series,
                     adscene=adscene)

    def adscene(self, code: str, i: int, first: int, last: int,
                light: tuple[float, str] | None) -> dict:
        """The event as an ADScene object; ``light``: where the light stands from the car's
        centre at ``first`` (m) and its colour (``None``: no light)."""
        path, speed = self.paths[i], self.record_speeds(i)
        frames = [frame_of(self.scene, i, k, float(speed[k]), float(path[k] - path[first]))
                  for k in range(first, last + 1)]
        track = self.scene.tracks[i]
        signs = [] if light is None else [{"position_longi_from_0": round(light[0], 2),
                                           "infrastructure_elements": [{
                                               "type": "TrafficSignType",
                                               "value": CODE_OF_STATE[light[1]]}]}]
        return adscene_header(self.scene, code, float(track.t[first]), float(track.t[last]),
                              signs, frames)

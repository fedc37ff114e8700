"""What every detector works with: a recording's tracks with smoothed motion and neighbour
queries (:class:`Scene`), and what it returns (:class:`Event`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from scenweave.mining.lanes import lane_map, on_path, path_from
from scenweave.mining.motion import (
    SMOOTHING,
    Motion,
    PositionsSpeed,
    lane_spacing,
    lateral_offsets,
    positions_speed,
    smooth_motion,
)
from scenweave.mining.tracks import Floats, Recording, Steps, Track
from scenweave.mining.traffic import Neighbour, Traffic
from scenweave.roads.recorded_road import LaneStrip

KMH = 3.6
#: a car is on another's path when its centre is within this of it (m) ...
ON_PATH_M = 1.6
#: ... heading its way within this (deg): a car crossing the path is no lead
ON_PATH_HEADING_DEG = 45.0
#: cars further apart than this (m, centres) are not looked at for a lead
LEAD_SEARCH_M = 90.0
#: a lead's path run on straight back from its first position is trusted to this (deg)
RUN_ON_SPREAD_DEG = 10.0
#: a point of the road is recorded when some car was recorded this close to it (m)
SEEN_WITHIN_M = 3.0


@dataclass(frozen=True)
class Event:
    """One manoeuvre found: its class, who plays the ego and the NPC, when, and the MOOVE
    fields of its record."""

    code: str
    ego: str
    npc: str | None
    start_s: float
    end_s: float
    fields: dict[str, float | str]
    #: the recorded series over the event (t from its start; speeds m/s; gap m)
    series: dict[str, Any] = field(default_factory=dict)
    #: urban events: the event as an ADScene object, MOOVE's urban file format
    adscene: dict | None = None
    #: why no scenario can play it, where the detector knows (it is reported, not written)
    refused: str | None = None


@dataclass
class Scene:
    """A recording with what every detector needs: smoothed motion and neighbour queries."""

    recording: Recording
    thresholds: dict[str, dict[str, float]]
    traffic: Traffic = field(init=False)
    motion: list[Motion] = field(init=False)
    #: each track's speed from its positions (0.5 s average) with its tracking noise: what a
    #: record's fields and series give, and scenarios are fitted to (``mining.motion``)
    positions: list[PositionsSpeed] = field(init=False)
    #: each track's lateral position (m, + left) from the road's course (``mining.motion``)
    lateral: list[Floats] = field(init=False)
    #: lane ``k``'s centre lies at ``lane_spacing * k`` of :attr:`lateral` (None: unknown)
    lane_spacing: float | None = field(init=False)

    def __post_init__(self) -> None:
        self.traffic = Traffic(self.recording)
        window = self.thresholds["smoothing"]["window_s"]
        self.positions = [positions_speed(track.t, track.s, track.speed)
                          for track in self.recording.tracks]
        self.motion = [smooth_motion(track, window, measured.noise)
                       for track, measured in zip(self.recording.tracks, self.positions,
                                                  strict=True)]
        self.lateral = lateral_offsets(self.recording.tracks)
        self.lane_spacing = lane_spacing(self.recording.tracks, self.lateral)

    @property
    def tracks(self) -> list[Track]:
        return self.recording.tracks

    @property
    def town(self) -> bool:
        """A town's recording (lights or junctions): lanes bend and end in junctions, so who
        drives ahead of whom is read from the path each car drives (:meth:`lead`)."""
        return bool(self.recording.lights or self.recording.junction_lanes)

    @cached_property
    def strips(self) -> dict[str, LaneStrip]:
        """The recording's lanelets (borders, neighbours) by the names ``Track.lane`` gives;
        empty where its file carries no lane map."""
        return lane_map(self.recording)

    def lead(self, i: int, k: int) -> Neighbour | None:
        """The car directly ahead of track ``i`` at its step ``k`` and the bumper gap: in
        town the nearest car on the path ``i`` drives next (junction lanes included), on a
        highway the next car of its lane."""
        if not self.town:
            return self.traffic.leader(i, k)
        return self._path_leads[i][k]

    def behind_in_lane(self, lead: int, m: int, follower: int, k: int) -> bool:
        """Whether track ``follower`` at its step ``k`` drives where track ``lead`` drove to
        reach its step ``m``: within :data:`ON_PATH_M` of the lead's earlier positions, run
        on straight back from the first of them with :data:`RUN_ON_SPREAD_DEG` of leeway (a
        heading at a track's start is a guess). On a highway the lanes say it
        (:meth:`lead`); in town a car that has a lead on the path it drives next may still
        be beside it, cutting in (Peachtree 2's 500 beside 512), or the lead may still be
        cutting in ahead of it."""
        if not self.town:
            return True
        car, me = self.tracks[lead], self.tracks[follower]
        behind = path_from(car.x[m::-1], car.y[m::-1], float(car.heading[0]) + np.pi)
        along, off, _ = on_path(behind, np.array([[me.x[k], me.y[k]]]))
        recorded = float(np.hypot(*np.diff(behind[:-1], axis=0).T).sum())
        beyond = max(float(along[0]) - recorded, 0.0)
        return bool(off[0] <= ON_PATH_M + beyond * np.tan(np.radians(RUN_ON_SPREAD_DEG)))

    def sees_ahead(self, i: int, k: int, distance_m: float) -> bool:
        """Whether the recording covers the road ``distance_m`` ahead of track ``i``'s front
        at its step ``k`` along the path it drives: some car was recorded within
        :data:`SEEN_WITHIN_M` of that point (a car beyond the recorded area could be
        close)."""
        me = self.tracks[i]
        path = path_from(me.x[k:], me.y[k:], float(me.heading[-1]))
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
        want = distance_m + me.length_m / 2
        point = [np.interp(want, along, path[:, 0]), np.interp(want, along, path[:, 1])]
        return bool(self._recorded_area.query_ball_point(point, SEEN_WITHIN_M,
                                                          return_length=True))

    @cached_property
    def _recorded_area(self) -> cKDTree:
        xy = [np.column_stack([tr.x, tr.y]) for tr in self.tracks]
        return cKDTree(np.concatenate(xy) if xy else np.zeros((0, 2)))

    def follower(self, i: int, k: int) -> Neighbour | None:
        """The car directly behind track ``i`` at its step ``k``: the one whose
        :meth:`lead` it is, nearest (a highway's: the previous car of its lane)."""
        if not self.town:
            return self.traffic.follower(i, k)
        return self._path_followers.get((i, k))

    @cached_property
    def _path_followers(self) -> dict[tuple[int, int], Neighbour]:
        """(track, step) -> the nearest car whose :meth:`lead` it is then."""
        found: dict[tuple[int, int], Neighbour] = {}
        for j, leads in enumerate(self._path_leads):
            for m, ahead in enumerate(leads):
                if ahead is None:
                    continue
                key = (ahead.track, ahead.step)
                if key not in found or ahead.gap_m < found[key].gap_m:
                    found[key] = Neighbour(j, m, ahead.gap_m)
        return found

    @cached_property
    def _path_leads(self) -> list[list[Neighbour | None]]:
        frames = _Frames(self.tracks, self.recording.dt or 0.1)
        return [[self._on_my_path(i, k, frames) for k in range(len(track.t))]
                for i, track in enumerate(self.tracks)]

    def _on_my_path(self, i: int, k: int, frames: _Frames) -> Neighbour | None:
        """The nearest car ahead on the path track ``i`` drives from step ``k`` (its later
        positions, then straight on), heading its way, and the bumper gap to it."""
        me = self.tracks[i]
        owner, step, xy, heading, length = frames.at(float(me.t[k]))
        near = (owner != i) & (np.hypot(*(xy - [me.x[k], me.y[k]]).T) <= LEAD_SEARCH_M)
        if not near.any():
            return None
        path = path_from(me.x[k:], me.y[k:], float(me.heading[-1]))
        along, off, course = on_path(path, xy[near])
        turn = np.abs(np.angle(np.exp(1j * (heading[near] - course))))
        gap = along - (me.length_m + length[near]) / 2
        good = (off <= ON_PATH_M) & (turn <= np.radians(ON_PATH_HEADING_DEG)) & (along > 0.5) \
            & (gap > -1.0)
        if not good.any():
            return None
        best = int(np.flatnonzero(good)[np.argmin(gap[good])])
        return Neighbour(int(owner[near][best]), int(step[near][best]), max(float(gap[best]), 0.0))

    def step_at(self, i: int, t: float) -> int | None:
        """Track ``i``'s step at time ``t`` (None when it was not seen then)."""
        track = self.tracks[i]
        if not len(track.t) or t < track.t[0] - 1e-6 or t > track.t[-1] + 1e-6:
            return None
        return int(np.argmin(np.abs(track.t - t)))

    def speed(self, i: int, t: float) -> float | None:
        step = self.step_at(i, t)
        return None if step is None else self.speed_at_step(i, step)

    def speed_at_step(self, i: int, step: int) -> float:
        """Track ``i``'s speed from its positions at ``step`` (what the record's series
        gives; at tracking noise, the nearest sample's that is not: ``PositionsSpeed.filled``)."""
        return float(self.positions[i].filled[step])

    def gap(self, ego: int, npc: int, t: float) -> float | None:
        """Signed bumper gap from ``ego`` to ``npc`` along the road (+: npc ahead)."""
        a, b = self.step_at(ego, t), self.step_at(npc, t)
        if a is None or b is None:
            return None
        me, other = self.tracks[ego], self.tracks[npc]
        centre = float(other.s[b] - me.s[a])
        room = (me.length_m + other.length_m) / 2
        return float(np.copysign(max(abs(centre) - room, 0.0), centre))  # side by side: 0

    def series(self, roles: dict[str, int], ego: int, start: float,
               end: float) -> dict[str, Any]:
        """Each role's speed, position along the road, lateral position and lane, and the
        NPCs' gaps to the ego, every step of the ego (``t`` from ``start``)."""
        track = self.tracks[ego]
        inside = (track.t >= start - 1e-6) & (track.t <= end + 1e-6)
        times = track.t[inside]
        found: dict[str, Any] = {"t": [round(float(t - start), 3) for t in times],
                                 "smoothing": SMOOTHING}
        for role, i in roles.items():
            steps = self._steps_at(i, times)
            other = self.tracks[i]
            measured = self.positions[i]
            found[f"{role}_speed_ms"] = self._values(measured.fitted, steps)
            found[f"{role}_speed_raw_ms"] = self._values(measured.speed, steps)
            found[f"{role}_noise"] = self._values(measured.noise.astype(float), steps)
            found[f"{role}_s_m"] = self._values(other.s, steps)
            found[f"{role}_lateral_m"] = self._values(self.lateral[i], steps)
            found[f"{role}_lane"] = self._values(other.lane_index, steps)
            found[f"{role}_lane_offset_m"] = self._values(self.lane_offset(i), steps)
            if role != "ego":
                room = (track.length_m + other.length_m) / 2
                centre = np.where(steps >= 0, other.s[np.maximum(steps, 0)] - track.s[inside],
                                  np.nan)
                gaps = np.copysign(np.maximum(np.abs(centre) - room, 0.0), centre)
                found[f"{role}_gap_m"] = self._values(gaps, np.arange(len(times)))
        return found

    def lane_offset(self, i: int) -> Floats:
        """Track ``i``'s offset from the centre of the lane it is labelled in (m, + left;
        NaN where the lanes' spacing or its lane is unknown): what a player's lane offset
        shows, to draw beside it."""
        track = self.tracks[i]
        if self.lane_spacing is None or len(track.lane_index) != len(track.t):
            return np.full(len(track.t), np.nan)
        return self.lateral[i] - self.lane_spacing * np.asarray(track.lane_index, dtype=float)

    def _steps_at(self, i: int, times: Floats) -> Steps:
        """Track ``i``'s step nearest each of ``times`` (-1 where it was not seen then)."""
        t = self.tracks[i].t
        if not len(t):
            return np.full(len(times), -1)
        k = np.clip(np.searchsorted(t, times), 1, max(len(t) - 1, 1))
        k = np.where(np.abs(t[k - 1] - times) <= np.abs(t[np.minimum(k, len(t) - 1)] - times),
                     k - 1, np.minimum(k, len(t) - 1))
        seen = (times >= t[0] - 1e-6) & (times <= t[-1] + 1e-6)
        return np.where(seen, k, -1)

    @staticmethod
    def _values(values: Floats, steps: Steps) -> list[float | None]:
        """``values`` at ``steps``, rounded; None where a step is -1 or a value unknown."""
        values = np.asarray(values, dtype=float)
        if not len(values):
            return [None] * len(steps)
        picked = np.round(values[np.clip(steps, 0, len(values) - 1)], 3)
        known = (steps >= 0) & (steps < len(values)) & np.isfinite(picked)
        return [v if ok else None for v, ok in zip(picked.tolist(), known.tolist(), strict=True)]


class _Frames:
    """Every track's position per frame of the recording, to find who is where at once."""

    def __init__(self, tracks: list[Track], dt: float):
        self.dt = dt
        rows = [(np.round(tr.t / dt).astype(int), np.full(len(tr.t), i), np.arange(len(tr.t)))
                for i, tr in enumerate(tracks)]
        frame = np.concatenate([r[0] for r in rows]) if rows else np.empty(0, int)
        order = np.argsort(frame, kind="stable")
        self.frame = frame[order]
        self.owner = np.concatenate([r[1] for r in rows])[order] if rows else frame
        self.step = np.concatenate([r[2] for r in rows])[order] if rows else frame
        def joined(name: str) -> Floats:
            return np.concatenate([np.asarray(getattr(tr, name), float) for tr in tracks])[order]

        self.xy = np.column_stack([joined("x"), joined("y")]) if rows else np.empty((0, 2))
        self.heading = joined("heading") if rows else np.empty(0)
        self.length = np.concatenate([np.full(len(tr.t), tr.length_m)
                                      for tr in tracks])[order] if rows else np.empty(0)

    def at(self, t: float) -> tuple[Steps, Steps, Floats, Floats, Floats]:
        """Owner, step, position, heading and length of every track seen at time ``t``."""
        f = int(round(t / self.dt))
        lo, hi = np.searchsorted(self.frame, f), np.searchsorted(self.frame, f, side="right")
        return (self.owner[lo:hi], self.step[lo:hi], self.xy[lo:hi], self.heading[lo:hi],
                self.length[lo:hi])


def make_event(scene: Scene, code: str, ego: int, npc: int | None, start: float, end: float,
               fields: dict[str, float | str]) -> Event:
    """An event of track ``ego`` (and ``npc``), its fields rounded, its series recorded."""
    roles = {"ego": ego} | ({"npc": npc} if npc is not None else {})
    kept = {k: round(v, 2) if isinstance(v, float) else v for k, v in fields.items()}
    return Event(code, scene.tracks[ego].id, None if npc is None else scene.tracks[npc].id,
                 round(start, 3), round(end, 3), kept, scene.series(roles, ego, start, end))


def vehicle(track: Track) -> str:
    return track.vehicle_type.capitalize()


def rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 3)

"""What every detector works with: a recording's tracks with smoothed motion and neighbour
queries (:class:`Scene`), and what it returns (:class:`Event`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from scenweave.mining.motion import Motion, lateral_offsets, smooth_motion
from scenweave.mining.tracks import Recording, Track
from scenweave.mining.traffic import Traffic

KMH = 3.6


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
    series: dict[str, list[float | None]] = field(default_factory=dict)
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
    #: each track's lateral position (m, + left) from the road's course (``mining.motion``)
    lateral: list[np.ndarray] = field(init=False)

    def __post_init__(self) -> None:
        self.traffic = Traffic(self.recording)
        window = self.thresholds["smoothing"]["window_s"]
        self.motion = [smooth_motion(track, window) for track in self.recording.tracks]
        self.lateral = lateral_offsets(self.recording.tracks)

    @property
    def tracks(self) -> list[Track]:
        return self.recording.tracks

    def step_at(self, i: int, t: float) -> int | None:
        """Track ``i``'s step at time ``t`` (None when it was not seen then)."""
        track = self.tracks[i]
        if not len(track.t) or t < track.t[0] - 1e-6 or t > track.t[-1] + 1e-6:
            return None
        return int(np.argmin(np.abs(track.t - t)))

    def speed(self, i: int, t: float) -> float | None:
        step = self.step_at(i, t)
        return None if step is None else float(self.motion[i].speed[step])

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
               end: float) -> dict[str, list[float | None]]:
        """Each role's speed, position along the road, lateral position and lane, and the
        NPCs' gaps to the ego, every step of the ego (``t`` from ``start``)."""
        track = self.tracks[ego]
        times = track.t[(track.t >= start - 1e-6) & (track.t <= end + 1e-6)]
        found: dict[str, list[float | None]] = {"t": [round(float(t - start), 3) for t in times]}
        for role, i in roles.items():
            steps = [self.step_at(i, t) for t in times]
            found[f"{role}_speed_ms"] = [rounded(self.speed(i, t)) for t in times]
            found[f"{role}_s_m"] = [self._at(self.tracks[i].s, k) for k in steps]
            found[f"{role}_lateral_m"] = [self._at(self.lateral[i], k) for k in steps]
            found[f"{role}_lane"] = [self._at(self.tracks[i].lane_index, k) for k in steps]
            if role != "ego":
                found[f"{role}_gap_m"] = [rounded(self.gap(ego, i, t)) for t in times]
        return found

    @staticmethod
    def _at(values: np.ndarray, step: int | None) -> float | None:
        if step is None or step >= len(values) or not np.isfinite(values[step]):
            return None
        return rounded(float(values[step]))


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

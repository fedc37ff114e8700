"""Who drives in front of and behind whom: a recording's tracks indexed by time step and lane.

``Traffic.leader(i, k)`` is the car directly ahead of track ``i`` at its step ``k`` in its lane
and the bumper gap to it; ``follower`` the one directly behind. Lanes are the tracks'
``lane_index`` where known (it stays the same along a road), else their ``lane`` names.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from scenweave.mining.tracks import Floats, Recording, Track

#: lane keys of different roads lie this far apart (beyond every lane name's code)
ROAD_STRIDE = 1e10
#: the owner of the rows of a vehicle the file took out (``Recording.removed``)
REMOVED = -1


@dataclass(frozen=True)
class Neighbour:
    """Another track, its step index at that moment, and the gap to it (m, bumper to bumper;
    positive)."""

    track: int
    step: int
    gap_m: float


class Traffic:
    """Neighbour queries over one recording."""

    def __init__(self, recording: Recording):
        self.recording = recording
        self.tracks = recording.tracks
        self.dt = recording.dt
        everyone = [*self.tracks, *recording.removed]
        named = {str(road) for track in everyone for road in track.road}
        roads = sorted(named | {road.rpartition("/")[2] for road in named})
        self._road_ids = {road: n for n, road in enumerate(roads, start=1)}
        self._keys = {id(track): self._lane_and_road(track, own=False) for track in everyone}
        rows = [self._rows(i, track) for i, track in enumerate(self.tracks)]
        rows += [self._rows(REMOVED, track) for track in recording.removed]
        table = np.concatenate(rows, axis=1) if rows else np.empty((4, 0))
        frame, lane, s, owner = table
        order = np.lexsort((s, lane, frame))
        self._frame, self._lane = frame[order], lane[order]
        self._s, self._owner = s[order], owner[order].astype(int)
        self._position = {(int(o), int(round(f))): k for k, (o, f) in
                          enumerate(zip(self._owner, self._frame, strict=True))}

    def frame(self, track: Track, step: int) -> int:
        return int(round(track.t[step] / self.dt))

    def lane_of(self, track: Track, step: int) -> float:
        """The lane's key at ``step``: equal for two cars in one lane of one road; a lane
        beside it is one more or less. Where ``Track.road`` is given, the road adds
        ``ROAD_STRIDE`` times its number (so the key changes where the car's road does, at a
        turn, and ``Track.lateral`` tells a lane change); without, the key is the lane index."""
        keys = self._keys.get(id(track))
        return float((self._lane_and_road(track, own=False) if keys is None else keys)[step])

    def _lane_and_road(self, track: Track, own: bool) -> Floats:
        """Lane keys with the road's number; ``own``: a road of the car's own (``"id/..."``,
        where its ``s`` is comparable with nobody's) counts, else only its direction."""
        keys = _lane_keys(track)
        if len(track.road) == len(track.t):  # lanes of different roads are different lanes
            roads = [str(r) if own else str(r).rpartition("/")[2] for r in track.road]
            keys = keys + ROAD_STRIDE * np.array([self._road_ids.get(r, 0) for r in roads])
        return keys

    def leader(self, i: int, step: int) -> Neighbour | None:
        return self._neighbour(i, step, +1)

    def follower(self, i: int, step: int) -> Neighbour | None:
        return self._neighbour(i, step, -1)

    def nearest_in_lane(self, i: int, step: int, lane: float) -> tuple[Neighbour | None, bool]:
        """The car of ``lane`` nearest to track ``i`` along the road at its ``step``, and
        whether it is ahead."""
        track = self.tracks[i]
        frame = self.frame(track, step)
        lo = np.searchsorted(self._frame, frame - 0.5)
        hi = np.searchsorted(self._frame, frame + 0.5)
        here = np.arange(lo, hi)[self._lane[lo:hi] == lane]
        here = here[(self._owner[here] != i) & (self._owner[here] != REMOVED)]
        if not len(here):
            return None, True
        offsets = self._s[here] - track.s[step]
        best = here[int(np.argmin(np.abs(offsets)))]
        ahead = bool(self._s[best] >= track.s[step])
        return self._as_neighbour(i, step, best, ahead), ahead

    def _neighbour(self, i: int, step: int, direction: int) -> Neighbour | None:
        k = self._position.get((i, self.frame(self.tracks[i], step)))
        if k is None:
            return None
        j = k + direction
        if not 0 <= j < len(self._frame) or self._frame[j] != self._frame[k] \
                or self._lane[j] != self._lane[k] or self._owner[j] == REMOVED:
            return None  # nobody there, or a car the file took out stands in between
        return self._as_neighbour(i, step, j, direction > 0)

    def _as_neighbour(self, i: int, step: int, row: int, ahead: bool) -> Neighbour:
        me, other = self.tracks[i], self.tracks[int(self._owner[row])]
        other_step = int(np.argmin(np.abs(other.t - me.t[step])))
        centre_gap = abs(float(self._s[row]) - float(me.s[step]))
        gap = centre_gap - (me.length_m + other.length_m) / 2
        return Neighbour(int(self._owner[row]), other_step, gap)

    def _rows(self, i: int, track: Track) -> Floats:
        frames = np.round(track.t / self.dt)
        lanes = self._lane_and_road(track, own=True)  # a car off its road's frame: alone
        return np.vstack([frames, lanes, track.s, np.full(len(track.t), i)])


def _lane_keys(track: Track) -> Floats:
    """A number per step naming the lane: the lane index where every step has one, else a
    stable code of the lane's name."""
    index = np.asarray(track.lane_index, dtype=float)
    if len(index) == len(track.t) and np.all(np.isfinite(index)):
        keys = index
    else:
        keys = np.array([_code(str(name)) for name in track.lane], dtype=float)
    return keys


def _code(name: str) -> float:
    """Lane names as numbers that never equal a lane index (indexes are small)."""
    return float(zlib.crc32(name.encode()) + 1000)

"""One record per event, even where recordings overlap.

Within a file the detectors already give one event per braking phase, lane change and
following episode. Across files, overlapping snippets of one road (NGSIM cut into CommonRoad
scenarios) hold the same vehicles at the same moments: :class:`Clock` finds how far apart
two recordings' time axes are from the vehicles they share (same id, same position), and
:class:`SeenEvents` drops an event whose class and vehicles match one already kept at an
overlapping absolute time.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from scenweave.mining.scene import Event
from scenweave.mining.tracks import Recording

#: a vehicle is the same one in two files when it stands this close at matched times (m)
SAME_PLACE_M = 0.5
#: the vehicles a recording shares with another must agree on the time shift this well (s)
SAME_SHIFT_S = 0.15


@dataclass
class Clock:
    """Absolute time across recordings: each recording's road (the first recording it shares
    vehicles with) and the offset of its time axis on that road's."""

    _seen: list[tuple[int, float, dict[str, tuple[np.ndarray, np.ndarray]]]] = \
        field(default_factory=list)

    def place(self, recording: Recording) -> tuple[int, float]:
        """``(road, offset_s)`` of ``recording``; a recording sharing nothing opens a road."""
        mine = {t.id: (t.t, np.column_stack([t.x, t.y])) for t in recording.tracks}
        placed = None
        for road, offset, theirs in self._seen:
            shift = _shift(mine, theirs)
            if shift is not None:
                placed = (road, offset + shift)
                break
        if placed is None:
            placed = (len(self._seen), 0.0)
        self._seen.append((placed[0], placed[1], mine))
        return placed


def _shift(mine: dict, theirs: dict) -> float | None:
    """How much later ``theirs``'s clock reads when the vehicles both hold stand where they
    stand (None: no vehicle in common)."""
    shifts = []
    for track_id, (t, xy) in mine.items():
        if track_id not in theirs:
            continue
        their_t, their_xy = theirs[track_id]
        distance = np.hypot(*(their_xy - xy[0]).T)
        k = int(np.argmin(distance))
        if distance[k] <= SAME_PLACE_M:
            shifts.append(float(their_t[k] - t[0]))
    if not shifts:
        return None
    middle = float(np.median(shifts))
    agreeing = [s for s in shifts if abs(s - middle) <= SAME_SHIFT_S]
    return middle if len(agreeing) * 2 > len(shifts) else None


@dataclass
class SeenEvents:
    """Events kept so far, by road, class and vehicles, with their absolute windows."""

    _kept: dict[tuple, list[tuple[float, float, str]]] = field(default_factory=dict)

    def duplicate_of(self, event: Event, road: int, offset_s: float, source: str) -> str | None:
        """The file of the kept event ``event`` repeats, else None (and ``event`` is kept)."""
        key = (road, event.code, event.ego, event.npc)
        start, end = event.start_s + offset_s, event.end_s + offset_s
        for first, last, where in self._kept.get(key, []):
            if start <= last + 1e-6 and first <= end + 1e-6:
                return where
        self._kept.setdefault(key, []).append((start, end, source))
        return None

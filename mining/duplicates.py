"""One record per event, even where recordings overlap.

Within a file the detectors already give one event per braking phase, lane change and
following episode. Across files, overlapping snippets of one road (NGSIM cut into CommonRoad
scenarios) hold the same vehicles at the same moments: :class:`Clock` finds how far apart
two recordings' time axes are from the vehicles they share (same id, the same recorded
speeds step by step, standing as far apart), and
:class:`SeenEvents` drops an event whose class and vehicles match one already kept at an
overlapping absolute time, naming the repeat's file in the kept record's provenance.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from scenweave.mining.scene import Event
from scenweave.mining.tracks import Floats, Recording

#: two files' clocks agree when a shared vehicle's recorded speeds match this well (m/s) over
#: at least :data:`MIN_MATCHED_STEPS` steps, at one time shift only
SAME_SPEED_MS = 0.01
MIN_MATCHED_STEPS = 20
#: ... and the matched speeds vary by at least this much (a near-steady speed, NGSIM's
#: 15.24 m/s plateaus, matches by chance), m/s
MIN_SPEED_RANGE_MS = 0.5
#: ... and two shared vehicles stand as far apart in both files, within this (m)
SAME_SPACING_M = 0.5
#: windows overlapping by more than this are one event (s)
OVERLAP_S = 0.05
#: the vehicles a recording shares with another must agree on the time shift this well (s)
SAME_SHIFT_S = 0.15

#: a vehicle's frame numbers (time over the recording's step)
Frames = npt.NDArray[np.int_]


@dataclass(frozen=True)
class _Seen:
    """What a recording's clock is matched by: per vehicle id its steps (frame numbers),
    recorded speeds and positions."""

    dt: float
    vehicles: dict[str, tuple[Frames, Floats, Floats]]


class Road:
    """One shared clock of recordings that overlap, directly or through others: a road found
    later to be the same as an earlier one is joined to it (:meth:`join`), its clock read on
    the earlier one's by a shift."""

    def __init__(self) -> None:
        self._parent: Road | None = None
        #: how much later the parent's clock reads at the same moment (s)
        self._shift_s = 0.0

    def root(self) -> tuple[Road, float]:
        """The road this one is part of, and how much later its clock reads than this one's."""
        road, shift = self, 0.0
        while road._parent is not None:
            road, shift = road._parent, shift + road._shift_s
        return road, shift

    def join(self, other: Road, shift_s: float) -> None:
        """``other`` is the same road: at the same moment this road's clock reads ``shift_s``
        later than ``other``'s."""
        mine, my_shift = self.root()
        theirs, their_shift = other.root()
        if theirs is not mine:
            theirs._parent, theirs._shift_s = mine, shift_s + my_shift - their_shift


@dataclass
class Clock:
    """Absolute time across recordings: each recording's road (the recordings it shares
    vehicles with, whichever of those it is, joined into one) and the offset of its time axis
    on that road's. Files cut from one recording may each have their own origin and
    orientation (CommonRoad puts each planning problem's start at 0, 0), so vehicles are
    matched by what no frame changes: their recorded speeds step by step, and the distance
    between two of them. A recording overlapping two that share nothing (B between A and C)
    joins their roads, so an event of C seen again in B is known as one."""

    _seen: list[tuple[Road, float, _Seen]] = field(default_factory=list)

    def place(self, recording: Recording) -> tuple[Road, float]:
        """``(road, offset_s)`` of ``recording``: a time ``t`` of it is ``t + offset_s`` on
        ``road``'s clock; a recording sharing nothing opens a road."""
        dt = recording.dt or 0.1
        mine = _Seen(dt, {t.id: (np.round(t.t / dt).astype(int), np.asarray(t.speed, float),
                                 np.column_stack([t.x, t.y])) for t in recording.tracks})
        placed: tuple[Road, float] | None = None
        for road, offset, theirs in self._seen:
            shift = _shift(mine, theirs)
            if shift is None:
                continue
            if placed is None:
                placed = (road, offset + shift)
            else:  # a second overlapping recording: its road is the same
                placed[0].join(road, placed[1] - offset - shift)
        if placed is None:
            placed = (Road(), 0.0)
        self._seen.append((placed[0], placed[1], mine))
        return placed


def _shift(mine: _Seen, theirs: _Seen) -> float | None:
    """How much later ``theirs``'s clock reads at the same moment (None: no vehicle in
    common, or the ones in common disagree)."""
    if abs(mine.dt - theirs.dt) > 1e-9:
        return None
    shifts = {}
    for vehicle in mine.vehicles.keys() & theirs.vehicles.keys():
        steps = _step_shift(mine.vehicles[vehicle][:2], theirs.vehicles[vehicle][:2])
        if steps is not None:
            shifts[vehicle] = steps
    if not shifts:
        return None
    middle = int(np.median(list(shifts.values())))
    agreeing = [v for v, d in shifts.items() if abs(d - middle) * mine.dt <= SAME_SHIFT_S]
    if len(agreeing) * 2 <= len(shifts) or not _same_spacing(mine, theirs, agreeing, middle):
        return None
    return middle * mine.dt


def _step_shift(mine: tuple[Frames, Floats], theirs: tuple[Frames, Floats]) -> int | None:
    """The one step shift ``d`` at which the vehicle's speeds in both files agree (``theirs``
    at frame ``f + d`` = ``mine`` at ``f``) over at least :data:`MIN_MATCHED_STEPS` steps in
    which they vary by :data:`MIN_SPEED_RANGE_MS` or more."""
    (f1, v1), (f2, v2) = mine, theirs
    found = []
    for d in range(int(f2[0] - f1[-1]), int(f2[-1] - f1[0]) + 1):
        common = np.intersect1d(f1 + d, f2)
        if len(common) < MIN_MATCHED_STEPS:
            continue
        a = v1[np.searchsorted(f1, common - d)]
        b = v2[np.searchsorted(f2, common)]
        if np.max(np.abs(a - b)) <= SAME_SPEED_MS and np.ptp(a) >= MIN_SPEED_RANGE_MS:
            found.append(d)
    return found[0] if len(found) == 1 else None  # a steady speed matches anywhere: unsure


def _same_spacing(mine: _Seen, theirs: _Seen, vehicles: list[str], steps: int) -> bool:
    """Two of the shared vehicles stand as far apart in both files at matched moments (the
    only check where one vehicle is shared: its speeds)."""
    if len(vehicles) < 2:
        return True
    (fa, _, xa), (fb, _, xb) = (mine.vehicles[v] for v in vehicles[:2])
    (ga, _, ya), (gb, _, yb) = (theirs.vehicles[v] for v in vehicles[:2])
    both = np.intersect1d(np.intersect1d(fa, fb), np.intersect1d(ga - steps, gb - steps))
    if not len(both):
        return True
    f = both[0]
    here = np.hypot(*(xa[np.searchsorted(fa, f)] - xb[np.searchsorted(fb, f)]))
    there = np.hypot(*(ya[np.searchsorted(ga, f + steps)] - yb[np.searchsorted(gb, f + steps)]))
    return abs(here - there) <= SAME_SPACING_M


@dataclass
class _Kept:
    """An event kept: its window on its road's clock, its file, and its record once made."""

    road: Road
    start_s: float
    end_s: float
    source: str
    record: dict | None = None

    def window(self) -> tuple[Road, float, float]:
        """The window on the clock of the road this one is now part of."""
        root, shift = self.road.root()
        return root, self.start_s + shift, self.end_s + shift


@dataclass
class SeenEvents:
    """Events kept so far, by class and vehicles, with their windows on their road's clock;
    a repeat is named in the kept record's provenance (``also_in``: file and window)."""

    _kept: dict[tuple[str, str, str | None], list[_Kept]] = field(default_factory=dict)

    def duplicate_of(self, event: Event, road: Road, offset_s: float,
                     source: str) -> str | None:
        """The file of the kept event ``event`` repeats (its record, when made, then names
        ``source`` too), else None (and ``event`` is kept)."""
        key = (event.code, event.ego, event.npc)
        here, shift = road.root()
        start, end = event.start_s + offset_s + shift, event.end_s + offset_s + shift
        for kept in self._kept.get(key, []):
            root, first, last = kept.window()
            if root is here and min(end, last) - max(start, first) > OVERLAP_S:
                _also_in(kept, source, event)  # consecutive pieces only touch
                return kept.source
        self._kept.setdefault(key, []).append(
            _Kept(road, event.start_s + offset_s, event.end_s + offset_s, source))
        return None

    def written(self, event: Event, record: dict) -> None:
        """``record`` is the kept ``event``'s: later repeats are named in its provenance."""
        for kept in reversed(self._kept.get((event.code, event.ego, event.npc), [])):
            if kept.record is None:
                kept.record = record
                return


def _also_in(kept: _Kept, source: str, event: Event) -> None:
    """Name the repeat's file and window in the kept record's provenance."""
    if kept.record is not None:
        kept.record.setdefault("provenance", {}).setdefault("also_in", []).append(
            {"file": source, "start_s": event.start_s, "end_s": event.end_s})

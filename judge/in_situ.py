"""An in-situ replay judged against the record: every recorded vehicle, every recorded sample.

The in-situ scenario (``scenario_lib.trajectories``) plays each recorded vehicle along its
recorded trajectory on the recorded road. Played (``player.Playback``), it must show what was
recorded, measured against the *raw* record (never only against the scenario's own copy of
it, which holds standstill jitter):

- position: the box centre within ``POSITION_TOL_M`` of the recorded position at every
  recorded sample (share and worst, per vehicle and overall); under ``MIN_SHARE`` of the
  samples within the tolerance, or a sample the scenario follows beyond ``POSITION_FAR_M``,
  is an error; samples the scenario holds as standstill noise count in the share and are
  named with their farthest offset (``IN_SITU_HELD``, a warning);
- heading: within ``HEADING_TOL_RAD`` (the same rules);
- speed: esmini's speed against the change of the recorded positions over the step before
  the sample (the records' own ``velocity`` contradicts their positions:
  docs/scenario-conventions.md, "In situ"); where the record steps backwards while the car
  stands (recorded noise: the scenario holds the car) the sample is named, not compared;
- collisions: a pair esmini reports touching whose recorded boxes never overlap around that
  time is an error (the record lacks that collision).

Findings are ``IN_SITU_*`` (``judge.findings``); the numbers are :class:`InSituVerdict`.
The record comes in as plain :class:`RecordedPath`\\ s (the judge imports no reader).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from scenweave.judge.findings import Finding
from scenweave.scenario_lib.trajectories import hold_backward

if TYPE_CHECKING:  # the player loads esmini's bindings: only the type is needed here
    from scenweave.player.playback import Playback

Floats = npt.NDArray[np.float64]

#: a played position may be this far from the recorded one (m); osc-validation's limit
POSITION_TOL_M = 0.1
#: a played position this far from the record is an error wherever it happens (m)
POSITION_FAR_M = 0.5
#: a played heading may differ this much from the recorded one (rad)
HEADING_TOL_RAD = 0.05
#: a played speed may differ this much from the recorded positions' change (m/s)
SPEED_TOL_MS = 0.1
#: under this share of samples within a tolerance is an error
MIN_SHARE = 0.995
#: speeds are compared from this sample of a vehicle's life on (the first has no recorded
#: step before it)
SPEED_FROM_SAMPLE = 1
#: recorded boxes closer than this count as touching (m): a collision within it is recorded
TOUCH_MARGIN_M = 0.1
#: a collision is looked for in the record this long around its time (s)
TOUCH_WINDOW_S = 0.2
#: a playback sample matches a recorded time within this (s)
TIME_MATCH_S = 1e-3


@dataclass(frozen=True)
class RecordedPath:
    """One vehicle as recorded: scenario times (s), box centre (m), heading (rad), size (m)."""

    name: str
    t: Sequence[float]
    x: Sequence[float]
    y: Sequence[float]
    heading: Sequence[float]
    length_m: float
    width_m: float


@dataclass
class Fit:
    """How closely one vehicle (or all of them) played its record."""

    samples: int = 0
    position_within: int = 0
    worst_position_m: float = 0.0
    worst_position_at_s: float | None = None
    heading_within: int = 0
    worst_heading_rad: float = 0.0
    worst_heading_at_s: float | None = None
    speed_samples: int = 0
    speed_within: int = 0
    worst_speed_ms: float = 0.0
    worst_speed_at_s: float | None = None
    #: steps of the record that are noise the scenario holds (a standing car stepping
    #: backwards and back): named, their speeds not compared
    backward_samples: int = 0
    #: the vehicle whose worst sample this is (overall fits)
    worst_position_of: str | None = None
    #: recorded samples the scenario holds off the record (standstill noise), and the
    #: farthest of them from its recorded position (m): named, not counted in the worst
    held_samples: int = 0
    worst_held_m: float = 0.0
    #: of those, how many the hold keeps more than the position tolerance off the record
    held_off: int = 0

    @property
    def position_share(self) -> float:
        return self.position_within / self.samples if self.samples else 1.0

    @property
    def followed_share(self) -> float:
        """The share within tolerance of the samples the scenario follows: held standstill
        noise is named (``IN_SITU_HELD``), not counted against the replay."""
        followed = self.samples - self.held_off
        return (self.position_within / followed) if followed > 0 else 1.0

    @property
    def heading_share(self) -> float:
        return self.heading_within / self.samples if self.samples else 1.0

    @property
    def speed_share(self) -> float:
        return self.speed_within / self.speed_samples if self.speed_samples else 1.0

    def add(self, other: Fit, name: str) -> None:
        """Count ``other`` (vehicle ``name``) into this overall fit."""
        self.samples += other.samples
        self.position_within += other.position_within
        self.heading_within += other.heading_within
        self.speed_samples += other.speed_samples
        self.speed_within += other.speed_within
        self.backward_samples += other.backward_samples
        self.held_samples += other.held_samples
        self.held_off += other.held_off
        self.worst_held_m = max(self.worst_held_m, other.worst_held_m)
        if other.worst_position_m >= self.worst_position_m:
            self.worst_position_m = other.worst_position_m
            self.worst_position_at_s = other.worst_position_at_s
            self.worst_position_of = name
        if other.worst_heading_rad >= self.worst_heading_rad:
            self.worst_heading_rad, self.worst_heading_at_s = (other.worst_heading_rad,
                                                               other.worst_heading_at_s)
        if other.worst_speed_ms >= self.worst_speed_ms:
            self.worst_speed_ms = other.worst_speed_ms
            self.worst_speed_at_s = other.worst_speed_at_s

    def to_dict(self) -> dict[str, Any]:
        def rounded(value: float | None, digits: int = 4) -> float | None:
            return None if value is None else round(value, digits)

        return {"samples": self.samples,
                "position": {"share": rounded(self.position_share, 5),
                             "worst_m": rounded(self.worst_position_m),
                             "worst_at_s": rounded(self.worst_position_at_s, 3),
                             **({"worst_of": self.worst_position_of}
                                if self.worst_position_of else {}),
                             "followed_share": rounded(self.followed_share, 5),
                             "held_samples": self.held_samples,
                             "held_off": self.held_off,
                             "worst_held_m": rounded(self.worst_held_m)},
                "heading": {"share": rounded(self.heading_share, 5),
                            "worst_rad": rounded(self.worst_heading_rad),
                            "worst_at_s": rounded(self.worst_heading_at_s, 3)},
                "speed": {"samples": self.speed_samples, "share": rounded(self.speed_share, 5),
                          "worst_ms": rounded(self.worst_speed_ms),
                          "worst_at_s": rounded(self.worst_speed_at_s, 3)},
                "record_steps_backwards": self.backward_samples}


@dataclass
class InSituVerdict:
    """The findings and the numbers of one in-situ replay."""

    findings: list[Finding] = field(default_factory=list)
    vehicles: dict[str, Fit] = field(default_factory=dict)
    overall: Fit = field(default_factory=Fit)
    #: collisions esmini reported that the record shows too (time, a, b)
    recorded_collisions: list[tuple[float, str, str]] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return not any(f.severity == "error" for f in self.findings)

    def to_dict(self) -> dict[str, Any]:
        return {"passed": self.passed,
                "findings": [f.to_dict() | {"t": f.time_s} for f in self.findings],
                "tolerances": {"position_m": POSITION_TOL_M, "position_far_m": POSITION_FAR_M,
                               "heading_rad": HEADING_TOL_RAD, "speed_ms": SPEED_TOL_MS,
                               "min_share": MIN_SHARE},
                "overall": self.overall.to_dict(),
                "vehicles": {name: fit.to_dict() for name, fit in self.vehicles.items()},
                "recorded_collisions": [list(c) for c in self.recorded_collisions]}


def judge_in_situ(playback: Playback, record: Iterable[RecordedPath],
                  skip: Collection[str] = ()) -> InSituVerdict:
    """``IN_SITU_*`` findings and the numbers of ``playback`` against ``record``; vehicles
    named in ``skip`` (an externally driven hero) are not compared."""
    verdict = InSituVerdict()
    if playback.engine_error or not playback.times:
        why = playback.engine_error or "esmini recorded no step"
        verdict.findings.append(Finding("IN_SITU_ENGINE", f"esmini could not play it: {why}"))
        return verdict
    paths = {p.name: p for p in record}
    for name, path in paths.items():
        if name in skip:
            continue
        if name not in playback.tracks:
            verdict.findings.append(Finding("IN_SITU_MISSING", f"{name} is recorded but not "
                                            "in the playback"))
            continue
        fit = vehicle_fit(playback, path)
        verdict.vehicles[name] = fit
        verdict.overall.add(fit, name)
    verdict.findings += _fit_findings(verdict)
    verdict.findings += _collision_findings(playback, paths, skip, verdict)
    return verdict


def _samples(playback: Playback, path: RecordedPath) -> tuple[npt.NDArray[np.intp], Floats]:
    """The playback's sample index at each recorded time (-1 where it has none), and times."""
    played = np.asarray(playback.times, dtype=float)
    recorded = np.asarray(path.t, dtype=float)
    k = np.clip(np.searchsorted(played, recorded - TIME_MATCH_S), 0, len(played) - 1)
    found = np.abs(played[k] - recorded) <= TIME_MATCH_S
    return np.where(found, k, -1), recorded


def vehicle_fit(playback: Playback, path: RecordedPath) -> Fit:
    """One vehicle's positions, headings and speeds against its record."""
    index, times = _samples(playback, path)
    seen = index >= 0
    track = playback.tracks[path.name]
    k = index[seen]
    t = times[seen]
    x, y, h = (np.asarray(path.x, float)[seen], np.asarray(path.y, float)[seen],
               np.asarray(path.heading, float)[seen])
    played_x, played_y = np.asarray(track["x"], float)[k], np.asarray(track["y"], float)[k]
    fit = Fit(samples=int(len(path.t)))  # an unplayed sample counts as a miss
    off = np.hypot(played_x - x, played_y - y)
    turned = np.abs(np.angle(np.exp(1j * (np.asarray(track["h"], float)[k] - h))))
    fit.position_within = int((off <= POSITION_TOL_M).sum())
    fit.heading_within = int((turned <= HEADING_TOL_RAD).sum())
    held = np.asarray(hold_backward(path.x, path.y, path.heading)[2], dtype=bool)[seen]
    fit.held_samples = int(held.sum())
    if held.any():
        fit.worst_held_m = float(off[held].max())
        fit.held_off = int((off[held] > POSITION_TOL_M).sum())
    if (~held).any():
        followed = np.where(held, -1.0, off)
        worst = int(np.argmax(followed))
        fit.worst_position_m, fit.worst_position_at_s = float(off[worst]), float(t[worst])
    if len(off):
        worst = int(np.argmax(turned))
        fit.worst_heading_rad, fit.worst_heading_at_s = float(turned[worst]), float(t[worst])
    if not seen.all():
        fit.worst_position_m = max(fit.worst_position_m, float("inf"))
        fit.worst_position_at_s = float(times[~seen][0])
    _speed_fit(fit, path, index, np.asarray(track["speed"], float))
    return fit


def recorded_speeds(path: RecordedPath) -> tuple[Floats, npt.NDArray[np.bool_]]:
    """Per sample from the second: the recorded positions' change over the step before it
    (m/s), and whether that step is recorded noise the scenario holds instead of following
    (a standing car's position stepping backwards, or stepping back to where it was held:
    ``scenario_lib.trajectories.hold_backward``)."""
    x, y, t = (np.asarray(v, dtype=float) for v in (path.x, path.y, path.t))
    held = np.asarray(hold_backward(path.x, path.y, path.heading)[2], dtype=bool)
    noise = held[1:] | held[:-1]
    return np.hypot(np.diff(x), np.diff(y)) / np.diff(t), noise


def _speed_fit(fit: Fit, path: RecordedPath, index: npt.NDArray[np.intp],
               played_speed: Floats) -> None:
    """Speeds from ``SPEED_FROM_SAMPLE`` on, where the scenario follows the record's step.
    esmini's speed at a sample is the distance moved over the step before it, as the
    record's is."""
    if len(path.t) < 2:
        return
    speeds, noise = recorded_speeds(path)
    k = index[1:]
    usable = (k >= 0) & ~noise
    usable[:max(SPEED_FROM_SAMPLE - 1, 0)] = False
    fit.backward_samples = int(noise.sum())
    # esmini signs a speed by the segment's direction against the heading: a standing car's
    # sideways jitter (kept; only backward steps are held) may come out negative
    difference = np.abs(np.abs(played_speed[k[usable]]) - speeds[usable])
    fit.speed_samples = int(usable.sum())
    fit.speed_within = int((difference <= SPEED_TOL_MS).sum())
    if len(difference):
        worst = int(np.argmax(difference))
        fit.worst_speed_ms = float(difference[worst])
        fit.worst_speed_at_s = float(np.asarray(path.t, float)[1:][usable][worst])


def _fit_findings(verdict: InSituVerdict) -> list[Finding]:
    """One finding per quantity that missed: an error past the hard limits, else a warning
    naming the share and the worst vehicle."""
    found: list[Finding] = []
    overall = verdict.overall
    if overall.samples == 0:
        return [Finding("IN_SITU_EMPTY", "no recorded sample to compare")]
    worst_of = overall.worst_position_of or "?"
    if overall.position_within < overall.samples:
        bad = overall.worst_position_m > POSITION_FAR_M or overall.followed_share < MIN_SHARE
        found.append(Finding(
            "IN_SITU_POSITION",
            f"{overall.position_share:.2%} of {overall.samples} recorded positions played within "
            f"{POSITION_TOL_M} m; worst where it follows the record {worst_of} "
            f"{overall.worst_position_m:.2f} m at {overall.worst_position_at_s or 0.0:.2f} s",
            "error" if bad else "warning", time_s=overall.worst_position_at_s))
    if overall.worst_held_m > POSITION_TOL_M:
        found.append(Finding(
            "IN_SITU_HELD",
            f"{overall.held_samples} recorded samples are standstill noise the scenario holds "
            f"(the record steps back and forth while the car stands), up to "
            f"{overall.worst_held_m:.2f} m from the recorded position", "warning"))
    if overall.heading_within < overall.samples:
        bad = overall.heading_share < MIN_SHARE
        found.append(Finding(
            "IN_SITU_HEADING",
            f"{overall.heading_share:.2%} of {overall.samples} recorded headings played within "
            f"{HEADING_TOL_RAD} rad; worst {overall.worst_heading_rad:.3f} rad at "
            f"{overall.worst_heading_at_s or 0.0:.2f} s", "error" if bad else "warning",
            time_s=overall.worst_heading_at_s))
    if overall.speed_within < overall.speed_samples:
        found.append(Finding(
            "IN_SITU_SPEED",
            f"{overall.speed_share:.2%} of {overall.speed_samples} speeds within "
            f"{SPEED_TOL_MS} m/s of the recorded positions' change; worst "
            f"{overall.worst_speed_ms:.2f} m/s at {overall.worst_speed_at_s or 0.0:.2f} s",
            "warning", time_s=overall.worst_speed_at_s))
    return found


def _collision_findings(playback: Playback, paths: dict[str, RecordedPath],
                        skip: Collection[str], verdict: InSituVerdict) -> list[Finding]:
    """One finding per pair and stretch of time esmini saw them touch where the record
    shows them apart."""
    step = (playback.times[1] - playback.times[0]) if len(playback.times) > 1 else 0.0
    unrecorded: dict[tuple[str, str], list[list[float]]] = {}
    for time_s, a, b in sorted(playback.collisions, key=lambda c: (c[1], c[2], c[0])):
        if a in skip or b in skip:
            continue
        if a in paths and b in paths and _recorded_touch(paths[a], paths[b], time_s):
            verdict.recorded_collisions.append((time_s, a, b))
            continue
        stretches = unrecorded.setdefault((a, b), [])
        if stretches and time_s - stretches[-1][1] <= step + TIME_MATCH_S:
            stretches[-1][1] = time_s
        else:
            stretches.append([time_s, time_s])
    return [Finding("IN_SITU_COLLISION", f"{a} and {b} collide from {first:.2f} s to "
                    f"{last:.2f} s; the record shows them apart", time_s=first)
            for (a, b), stretches in sorted(unrecorded.items()) for first, last in stretches]


def _recorded_touch(a: RecordedPath, b: RecordedPath, time_s: float) -> bool:
    """Whether the recorded boxes of ``a`` and ``b`` come within ``TOUCH_MARGIN_M`` of each
    other within ``TOUCH_WINDOW_S`` of ``time_s``."""
    ta, tb = np.asarray(a.t, float), np.asarray(b.t, float)
    for i in np.flatnonzero(np.abs(ta - time_s) <= TOUCH_WINDOW_S + TIME_MATCH_S):
        j = int(np.argmin(np.abs(tb - ta[i])))
        if abs(tb[j] - ta[i]) > TIME_MATCH_S:
            continue
        if boxes_touch(_corners(a, int(i)), _corners(b, j), TOUCH_MARGIN_M):
            return True
    return False


def _corners(path: RecordedPath, k: int) -> Floats:
    """The four corners of ``path``'s recorded box at sample ``k``."""
    h = float(path.heading[k])
    along, across = np.array([np.cos(h), np.sin(h)]), np.array([-np.sin(h), np.cos(h)])
    centre = np.array([path.x[k], path.y[k]], dtype=float)
    half_l, half_w = path.length_m / 2, path.width_m / 2
    return np.array([centre + sl * half_l * along + sw * half_w * across
                     for sl, sw in ((1, 1), (1, -1), (-1, -1), (-1, 1))])


def boxes_touch(a: Floats, b: Floats, margin_m: float = 0.0) -> bool:
    """Whether two convex quadrilaterals (corners in order) come within ``margin_m``: no
    separating axis among their edges' normals with a gap wider than the margin."""
    for corners in (a, b):
        for edge in np.diff(np.vstack([corners, corners[:1]]), axis=0):
            normal = np.array([-edge[1], edge[0]]) / (np.hypot(*edge) or 1.0)
            pa, pb = a @ normal, b @ normal
            if pa.min() > pb.max() + margin_m or pb.min() > pa.max() + margin_m:
                return False
    return True

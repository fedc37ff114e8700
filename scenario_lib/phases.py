"""One actor's longitudinal motion as data: a start speed and a list of speed phases.

A phase is one speed change: from ``start_s`` (simulation time) the actor goes from whatever
speed it has to ``target_ms`` within ``duration_s``, along ``shape`` (OpenSCENARIO's
``DynamicsShapes``). Between phases, and after the last, it holds its speed. A profile of one
linear phase is the single ramp every reference scenario had before phases existed
(``scenario_lib.kinematics.SpeedProfile``); params carry the list as ``<actor>_phases``
(docs/params.md), the scripts play each phase as one speed action (``builder``), and the
checks read them back through :func:`phases_of`. This is the one place the phase model lives.

Imports nothing but the standard library and ``kinematics``: it runs in the sandbox too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, TypedDict, TypeGuard

from scenweave.scenario_lib.kinematics import (
    LANE_CHANGE_MIN_LENGTH_M,
    SpeedProfile,
    lane_change_length_m,
)

Shape = Literal["linear", "cubic", "sinusoidal", "step"]
SHAPES: tuple[str, ...] = ("linear", "cubic", "sinusoidal", "step")
#: the actors whose motion params may give as phases (``<actor>_phases``): the highway ego and
#: NPC, the free-ride slots
PHASED_ACTORS = ("ego", "npc", "center", "right", "left")
#: phases may overlap by this much (s): rounding to the millisecond
OVERLAP_TOL_S = 1e-6


class PhaseRecord(TypedDict):
    """A phase as params hold it (JSON): the contract's form of :class:`Phase`."""

    start_s: float
    duration_s: float
    target_ms: float
    shape: Shape


@dataclass(frozen=True)
class Phase:
    """From ``start_s`` to ``target_ms`` within ``duration_s`` (s, m/s), along ``shape``."""

    start_s: float
    duration_s: float
    target_ms: float
    shape: str = "linear"

    @property
    def end_s(self) -> float:
        return self.start_s + max(self.duration_s, 0.0)

    def record(self) -> dict[str, Any]:
        """The params form (``PhaseRecord``)."""
        return {"start_s": self.start_s, "duration_s": self.duration_s,
                "target_ms": self.target_ms, "shape": self.shape}

    def progress(self, t: float) -> float:
        """Share of the speed change done at ``t`` (0 before, 1 after)."""
        if t <= self.start_s:
            return 0.0
        if self.shape == "step" or self.duration_s <= 0 or t >= self.end_s:
            return 1.0
        u = (t - self.start_s) / self.duration_s
        if self.shape == "cubic":
            return u * u * (3 - 2 * u)
        if self.shape == "sinusoidal":
            return (1 - math.cos(math.pi * u)) / 2
        return u

    def area(self, t: float) -> float:
        """Integral of ``progress`` from ``start_s`` to ``t`` (s)."""
        if t <= self.start_s:
            return 0.0
        if self.shape == "step" or self.duration_s <= 0:
            return t - self.start_s
        u = min((t - self.start_s) / self.duration_s, 1.0)
        if self.shape == "cubic":
            within = u ** 3 - u ** 4 / 2
        elif self.shape == "sinusoidal":
            within = u / 2 - math.sin(math.pi * u) / (2 * math.pi)
        else:
            within = u * u / 2
        return within * self.duration_s + max(t - self.end_s, 0.0)


class PhasesInvalid(ValueError):
    """A phase list no scenario can play: the message says which phase and why."""


def parse_phases(value: Any, what: str = "phases") -> tuple[Phase, ...]:
    """The phases of a params value (a list of ``PhaseRecord``), checked: finite numbers,
    durations >= 0, targets >= 0, a known shape, in time order without overlap."""
    if not isinstance(value, Sequence) or isinstance(value, str):
        raise PhasesInvalid(f"{what} must be a list of phases, not {value!r}")
    phases: list[Phase] = []
    for i, item in enumerate(value):
        if not isinstance(item, Mapping):
            raise PhasesInvalid(f"{what}[{i}] must be an object, not {item!r}")
        numbers = [item.get(k) for k in ("start_s", "duration_s", "target_ms")]
        if not all(_finite(n) for n in numbers):
            raise PhasesInvalid(f"{what}[{i}] needs finite start_s, duration_s and target_ms, "
                                f"not {dict(item)!r}")
        shape = item.get("shape", "linear")
        if shape not in SHAPES:
            raise PhasesInvalid(f"{what}[{i}].shape must be one of {list(SHAPES)}, not {shape!r}")
        start, duration, target = (float(n) for n in numbers if _finite(n))
        phase = Phase(start, duration, target, shape)
        if phase.duration_s < 0 or phase.target_ms < 0 or phase.start_s < 0:
            raise PhasesInvalid(f"{what}[{i}]: start, duration and target speed must be >= 0")
        if phases and phase.start_s < phases[-1].end_s - OVERLAP_TOL_S:
            raise PhasesInvalid(f"{what}[{i}] starts at {phase.start_s:g} s, before phase {i - 1} "
                                f"ends ({phases[-1].end_s:g} s)")
        phases.append(phase)
    return tuple(phases)


@dataclass(frozen=True)
class PhasedProfile:
    """Speed ``v0`` until the first phase starts, then each phase in turn (holding between).

    Duck-compatible with ``SpeedProfile`` (``speed``, ``distance``, ``time_to_cover``,
    ``breakpoints``, ``end_speed``), so the timing rules of ``kinematics`` take either.
    """

    v0: float
    phases: tuple[Phase, ...]

    @property
    def end_speed(self) -> float:
        return self.phases[-1].target_ms if self.phases else self.v0

    @property
    def start_s(self) -> float:
        return self.phases[0].start_s if self.phases else 0.0

    @property
    def end_s(self) -> float:
        return self.phases[-1].end_s if self.phases else 0.0

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def _starts(self) -> list[float]:
        """The speed each phase starts from."""
        speeds, v = [], self.v0
        for phase in self.phases:
            speeds.append(v)
            v = phase.target_ms
        return speeds

    def speed(self, t: float) -> float:
        v = self.v0
        for phase, begin in zip(self.phases, self._starts(), strict=True):
            if t <= phase.start_s:
                return v
            v = begin + (phase.target_ms - begin) * phase.progress(t)
        return v

    def distance(self, t: float) -> float:
        """Metres driven from t = 0 to ``t``."""
        covered, now, v = 0.0, 0.0, self.v0
        for phase, begin in zip(self.phases, self._starts(), strict=True):
            if t <= phase.start_s:
                break
            covered += v * (phase.start_s - now)
            until = min(t, phase.end_s)
            covered += begin * (until - phase.start_s) + \
                (phase.target_ms - begin) * phase.area(until)
            now, v = until, phase.target_ms
        return covered + v * max(t - now, 0.0)

    def time_to_cover(self, metres: float) -> float:
        """When the car has driven ``metres`` (``math.inf`` if it stops first)."""
        if metres <= 0:
            return 0.0
        end = self.end_s
        if self.distance(end) < metres:
            return end + (metres - self.distance(end)) / self.end_speed \
                if self.end_speed > 0 else math.inf
        low, high = 0.0, end
        for _ in range(60):
            middle = (low + high) / 2
            low, high = (low, middle) if self.distance(middle) >= metres else (middle, high)
        return high

    def breakpoints(self) -> tuple[float, ...]:
        return tuple(t for phase in self.phases for t in (phase.start_s, phase.end_s))

    def hardest_braking_ms2(self) -> float:
        """How hard the hardest-braking phase slows down (m/s^2)."""
        return self.max_acceleration_ms2(braking_only=True)

    def max_acceleration_ms2(self, braking_only: bool = False) -> float:
        """The largest mean speed change per second of any phase (m/s^2, either way, or only
        slowing down)."""
        worst = 0.0
        for phase, begin in zip(self.phases, self._starts(), strict=True):
            change = begin - phase.target_ms if braking_only else abs(phase.target_ms - begin)
            if change > 0:
                worst = max(worst, math.inf if phase.duration_s <= 0 else
                            change / phase.duration_s)
        return worst


def default_phases(params: Mapping[str, Any], actor: str) -> tuple[Phase, ...]:
    """The single ramp params describe without phases: ``<actor>_speed_ms`` to
    ``<actor>_end_speed_ms`` over ``duration_s`` from ``maneuver_start_s``."""
    return (Phase(params["maneuver_start_s"], params["duration_s"],
                  params[f"{actor}_end_speed_ms"]),)


def phases_of(params: Mapping[str, Any], actor: str) -> tuple[Phase, ...]:
    """``actor``'s phases: ``<actor>_phases`` when params give them, else the single ramp."""
    given = params.get(f"{actor}_phases")
    if given is None:
        return default_phases(params, actor)
    return parse_phases(given, f"params key {actor + '_phases'!r}")


def is_single_ramp(params: Mapping[str, Any], actor: str) -> bool:
    """Whether ``actor`` drives the one ramp params describe anyway (no phases, or one phase
    equal to it): the scenario is then the same as before phases existed."""
    given = params.get(f"{actor}_phases")
    return given is None or phases_of(params, actor) == default_phases(params, actor)


def hardest_second(t: Sequence[float], v: Sequence[float]) -> float:
    """The most speed lost within one second over samples at times ``t`` (m/s): how hard a
    brake was, which the fit keeps and the judge reports (issue 31)."""
    best = 0.0
    for k, (now, speed) in enumerate(zip(t, v, strict=True)):
        later = [w for u, w in zip(t[k + 1:], v[k + 1:], strict=True) if u <= now + 1.0 + 1e-6]
        if later:
            best = max(best, speed - min(later))
    return best


def profile_of(params: Mapping[str, Any], actor: str) -> SpeedProfile | PhasedProfile:
    """``actor``'s motion from t = 0: the single-ramp ``SpeedProfile`` when that is what it
    drives (the same arithmetic as before phases), else its ``PhasedProfile``."""
    v0 = params[f"{actor}_speed_ms"]
    if is_single_ramp(params, actor):
        return SpeedProfile(v0, params[f"{actor}_end_speed_ms"], params["maneuver_start_s"],
                            params["duration_s"])
    return PhasedProfile(v0, phases_of(params, actor))


def lane_change_length(params: Mapping[str, Any], actor: str) -> float:
    """The length (m) ``actor``'s lane change is given so it takes ``duration_s`` from
    ``maneuver_start_s``: the distance its profile drives meanwhile (for the single ramp,
    ``kinematics.lane_change_length_m`` of its start and end speeds)."""
    start, duration = params["maneuver_start_s"], params["duration_s"]
    if is_single_ramp(params, actor):
        return lane_change_length_m(params[f"{actor}_speed_ms"], params[f"{actor}_end_speed_ms"],
                                    duration)
    profile = profile_of(params, actor)
    return max(LANE_CHANGE_MIN_LENGTH_M,
               round(profile.distance(start + duration) - profile.distance(start), 3))


def _finite(value: object) -> TypeGuard[int | float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)

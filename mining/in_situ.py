"""A mined event where it happened: the recorded road and every vehicle recorded around it.

``write_in_situ(recording, event, out_dir, road, settings)`` writes ``<out_dir>/in_situ/``:
``scenario.xosc`` (OpenSCENARIO 1.0, ``scenario_lib.trajectories``), ``road.xodr`` (the
recording's converted road, linked or copied), ``in_situ.json`` (what was chosen: file, ego,
tracks, window, held samples) and, when played, ``replay.json`` and ``judge.json`` (the
judge's findings and numbers, ``judge.in_situ``, and the OpenSCENARIO 1.0 XSD's); with
``external_ego`` also ``hero_reference.csv`` (the ego's recorded trajectory, the stack's
reference). The folder appears whole or not at all.

What is chosen (:func:`choose`): the event's window widened by ``context_s`` on both sides and
clipped to the ego's track (the scenario is the ego's: t = 0 is where it starts); every
vehicle recorded in it, each cut to the window, named ``v<track id>`` (the ego ``hero``, its
track id a property), with its recorded size and kind. Where a standing car's recorded
position steps backwards (NGSIM jitters up to 0.45 m), the trajectory holds it: the backward
part of the step is dropped, so no car reverses. A track with a gap in the window, a vehicle
without a size, or a road that cannot be converted refuses the in-situ scenario
(:class:`InSituRefused`, one line naming the file and the track or lanelet); the event's
other scenarios are not affected.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from lxml import etree

from scenweave.errors import InputError
from scenweave.files import write_json_atomic, write_text_atomic
from scenweave.judge.in_situ import InSituVerdict, RecordedPath, judge_in_situ
from scenweave.judge.validate_xosc import xsd_findings
from scenweave.mining.detect import Event
from scenweave.mining.tracks import Floats, Recording, Track, TrafficLight
from scenweave.scenario_lib.builder import HERO, write_scenario
from scenweave.scenario_lib.trajectories import (
    InSituScene,
    RecordedVehicle,
    SignalController,
    SignalPhase,
    hold_backward,
    in_situ_scenario,
    reference_csv,
    scenario_summary,
)
from scenweave.schemas.scenario_folder import (
    HERO_REFERENCE_NAME,
    IN_SITU_CHOICE_NAME,
    IN_SITU_DIR,
    IN_SITU_REPORT_NAME,
    IN_SITU_VERDICT_NAME,
    REPLAY_NAME,
    ROAD_NAME,
    XOSC_NAME,
)

#: a step longer than this many recording steps is a gap in the track
GAP_STEPS = 1.5
#: a trajectory vertex is left out where the line between its neighbours passes within this
#: of it (m; rad for the heading): the player's speed over a step then differs from the
#: recorded positions' change by at most 2 x this / the step (0.1 m/s at 0.1 s)
THIN_TOLERANCE = 0.005
#: parked cars wait this far beyond the recorded traffic (m)
PARKING_OFFSET_M = 150.0


class InSituRefused(InputError):
    """The in-situ scenario of an event cannot be made from its recording; the message is one
    line naming the file and the track or lanelet."""


#: what a record the checks let through can still raise deep in the making of its in-situ
#: scenario (a window outside its recording, a NaN, an empty series, a missing key): refused
#: like :class:`InSituRefused`, one line, and the batch goes on (``refusal``)
REFUSED_ERRORS: tuple[type[Exception], ...] = (InputError, ValueError, ArithmeticError,
                                               LookupError)


def refusal(err: Exception, source: str) -> str:
    """The one line an in-situ scenario refused for ``err`` is reported with, by ``mine
    --in-situ`` and by ``run`` alike: an InputError's own message (it names the file and the
    track), else the file and the error."""
    if isinstance(err, InputError):
        return str(err)
    return f"{source}: the in-situ scenario could not be made: {err!r}"


@dataclass(frozen=True)
class InSituSettings:
    """How in-situ scenarios are made (``scenweave mine --in-situ``)."""

    #: seconds of recording kept before and after the event
    context_s: float = 3.0
    #: hand the ego to an external controller (the stack under test)
    external_ego: bool = False
    #: play the scenario in esmini and judge it against the record
    replay: bool = True
    #: the player's wall-clock limit per scenario (s)
    wall_time_s: float = 30.0


@dataclass(frozen=True)
class RecordedRoad:
    """The recording's road as OpenDRIVE and its traffic lights' signal ids."""

    xodr: Path
    #: recorded light id -> the OpenDRIVE signal ids that show it
    signals: Mapping[str, Sequence[str]] = field(default_factory=dict)


@dataclass(frozen=True)
class EventWindow:
    """Which ego and when: a mined event's or a mined record's."""

    ego: str
    start_s: float
    end_s: float
    label: str = ""


@dataclass
class InSituChoice:
    """What the in-situ scenario plays: times from the window's start."""

    source: str
    ego: str
    start_s: float
    end_s: float
    vehicles: list[RecordedVehicle]
    record: list[RecordedPath]
    held_samples: int
    step_s: float

    def to_dict(self) -> dict[str, Any]:
        tracks = {v.name: v.properties.get("track_id", v.name.removeprefix("v"))
                  for v in self.vehicles}
        # when each vehicle is on the road (scenario time); parked (far away) outside it
        life = {p.name: [round(float(p.t[0]), 3), round(float(p.t[-1]), 3)]
                for p in self.record}
        return {"file": self.source, "ego_track": self.ego,
                "window_s": [round(self.start_s, 3), round(self.end_s, 3)],
                "tracks": tracks, "life_s": life, "held_backward_samples": self.held_samples,
                "step_s": self.step_s}


@dataclass
class InSituResult:
    """What ``write_in_situ`` wrote and what the judge found (``verdict`` None: not played)."""

    folder: Path
    scenario: Path
    choice: InSituChoice
    verdict: InSituVerdict | None = None
    timings_s: dict[str, float] = field(default_factory=dict)


def window_of(event: Event | Mapping[str, Any]) -> EventWindow:
    """The ego and window of a mined :class:`Event` or of a mined record (its provenance)."""
    if isinstance(event, Event):
        return EventWindow(event.ego, event.start_s, event.end_s, event.code)
    provenance = event.get("provenance") or {}
    try:
        return EventWindow(str(provenance["tracks"]["ego"]), float(provenance["start_s"]),
                           float(provenance["end_s"]), str(event.get("scenario_id", "")))
    except (KeyError, TypeError, ValueError) as err:
        raise InSituRefused(f"record {event.get('scenario_id', '?')}: no provenance "
                            f"(tracks.ego, start_s, end_s) to find it in its recording: "
                            f"{err!r}") from err


def choose(recording: Recording, window: EventWindow, context_s: float = 3.0) -> InSituChoice:
    """Every vehicle recorded in ``window`` widened by ``context_s`` (clipped to the ego's
    track), cut to it and checked; :class:`InSituRefused` naming file and track otherwise."""
    source = recording.source
    ego = next((t for t in recording.tracks if t.id == window.ego), None)
    if ego is None:
        raise InSituRefused(f"{source}: track {window.ego} (the event's ego) is not in the "
                            "recording")
    start = _on_grid(ego.t, max(window.start_s - context_s, float(ego.t[0])))
    end = min(window.end_s + context_s, float(ego.t[-1]))
    dt = recording.dt or 0.1
    vehicles, record, held = [], [], 0
    for track in recording.tracks:
        inside = (track.t >= start - 1e-6) & (track.t <= end + 1e-6)
        if inside.sum() < 2:
            continue
        _check_track(source, track, inside, dt)
        name = HERO if track.id == window.ego else f"v{track.id}"
        vehicle, path, backward = _vehicle(track, inside, start, name)
        vehicles.append(vehicle)
        record.append(path)
        held += backward
    return InSituChoice(source, window.ego, start, end, vehicles, record, held, dt)


def _on_grid(times: np.ndarray, at_s: float) -> float:
    """The first recorded time at or after ``at_s``: scenario times are then the recording's
    own steps, which the player's clock lands on."""
    return float(times[min(int(np.searchsorted(times, at_s - 1e-6)), len(times) - 1)])


def _check_track(source: str, track: Track, inside: np.ndarray, dt: float) -> None:
    """A track the scenario can play: a size, no gap, finite positions within the window."""
    for what, value in (("length", track.length_m), ("width", track.width_m)):
        if not math.isfinite(value) or value <= 0:
            raise InSituRefused(f"{source}: track {track.id} has no {what} ({value!r}): a "
                                "vehicle without a size cannot be played")
    t = track.t[inside]
    steps = np.diff(t)
    if len(steps) and steps.max() > GAP_STEPS * dt:
        k = int(np.argmax(steps))
        raise InSituRefused(f"{source}: track {track.id} has a gap from {t[k]:.2f} s to "
                            f"{t[k + 1]:.2f} s (no position for {steps[k]:.2f} s)")
    values = np.concatenate([track.x[inside], track.y[inside], track.heading[inside]])
    if not np.isfinite(values).all():
        raise InSituRefused(f"{source}: track {track.id} has a position or heading that is "
                            "not a number within the event's window")


def _vehicle(track: Track, inside: np.ndarray, start: float,
             name: str) -> tuple[RecordedVehicle, RecordedPath, int]:
    """The scenario's vehicle (jitter held) and the raw record it is judged against."""
    t = np.round(track.t[inside] - start, 3)
    x, y, h = track.x[inside], track.y[inside], track.heading[inside]
    held_x, held_y, held = hold_backward(x, y, h)
    keep = thinned(t, np.asarray(held_x), np.asarray(held_y), h)
    properties = {"track_id": track.id} if name == HERO else {}
    vehicle = RecordedVehicle(name, track.vehicle_type, track.length_m, track.width_m,
                              t[keep].tolist(), np.asarray(held_x)[keep].tolist(),
                              np.asarray(held_y)[keep].tolist(), h[keep].tolist(), properties)
    path = RecordedPath(name, t.tolist(), x.tolist(), y.tolist(), h.tolist(), track.length_m,
                        track.width_m)
    return vehicle, path, int(sum(held))


def thinned(t: Floats, x: Floats, y: Floats, heading: Floats,
            tolerance: float = THIN_TOLERANCE) -> npt.NDArray[np.intp]:
    """The samples a trajectory needs: those the straight line in time between their
    neighbours kept misses by more than ``tolerance`` (m, and rad for the heading); the rest
    the player interpolates as recorded (Douglas-Peucker in time). esmini places every vertex
    on the road network when it loads a scenario, most of an in-situ replay's cost, and a car
    driving steadily needs few."""
    turn = np.unwrap(heading)
    keep = np.zeros(len(t), dtype=bool)
    keep[[0, -1]] = True
    spans = [(0, len(t) - 1)]
    while spans:
        first, last = spans.pop()
        if last - first < 2:
            continue
        inner = slice(first + 1, last)
        share = (t[inner] - t[first]) / (t[last] - t[first])
        miss = np.maximum(
            np.hypot(x[first] + share * (x[last] - x[first]) - x[inner],
                     y[first] + share * (y[last] - y[first]) - y[inner]),
            np.abs(turn[first] + share * (turn[last] - turn[first]) - turn[inner]))
        worst = int(np.argmax(miss))
        if miss[worst] > tolerance:
            split = first + 1 + worst
            keep[split] = True
            spans += [(first, split), (split, last)]
    return np.flatnonzero(keep)


def light_controllers(lights: Sequence[TrafficLight], signals: Mapping[str, Sequence[str]],
                      start_s: float, end_s: float) -> list[SignalController]:
    """One controller per recorded light the road shows as signals: its recorded states
    over the window as phases from t = 0 (``off`` where the record says nothing)."""
    controllers = []
    for light in lights:
        ids = signals.get(light.id) or ()
        if not ids:
            continue
        phases, now = [], start_s
        for phase in sorted(light.phases, key=lambda p: p.start_s):
            begin, stop = max(phase.start_s, start_s), min(phase.end_s, end_s)
            if stop <= begin:
                continue
            if begin > now + 1e-6:
                phases.append(SignalPhase(begin - now, {i: "off" for i in ids}))
            phases.append(SignalPhase(stop - begin, {i: phase.state for i in ids}))
            now = stop
        if phases:
            controllers.append(SignalController(f"light_{light.id}", phases))
    return controllers


def _parking(recording: Recording) -> tuple[float, float]:
    """The first parking slot: left of and below every recorded position."""
    xs = [float(np.nanmin(t.x)) for t in recording.tracks if len(t.x)]
    ys = [float(np.nanmin(t.y)) for t in recording.tracks if len(t.y)]
    return (min(xs, default=0.0), min(ys, default=0.0) - PARKING_OFFSET_M)


def scene_of(recording: Recording, choice: InSituChoice, road: RecordedRoad,
             window: EventWindow, external: bool) -> InSituScene:
    """The scenario's content: the chosen vehicles on the road, the lights, the hero."""
    duration = round(choice.end_s - choice.start_s, 3)
    description = (f"ScenWeave in situ {window.label} {Path(recording.source).name} "
                   f"ego {choice.ego} {choice.start_s:.1f}-{choice.end_s:.1f} s").strip()
    return InSituScene(description, ROAD_NAME, duration, choice.vehicles, _parking(recording),
                       choice.step_s,
                       light_controllers(recording.lights, road.signals, choice.start_s,
                                         choice.end_s),
                       external=external, reference_file=HERO_REFERENCE_NAME if external else None)


def write_in_situ(recording: Recording, event: Event | Mapping[str, Any], out_dir: Path,
                  road: RecordedRoad, settings: InSituSettings | None = None,
                  name: str = IN_SITU_DIR) -> InSituResult:
    """Write ``<out_dir>/<name>/`` (default ``in_situ``) for ``event`` of ``recording`` (see
    the module's docstring); played and judged unless ``settings.replay`` is off. Raises
    :class:`InSituRefused` (one line) for input it cannot play; the folder is then not
    written. ``PlayerUnavailable`` when a replay is asked for and there is no esmini."""
    settings = settings or InSituSettings()
    started = time.perf_counter()
    window = window_of(event)
    choice = choose(recording, window, settings.context_s)
    scene = scene_of(recording, choice, road, window, settings.external_ego)
    folder = Path(out_dir) / name
    staging = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=_made(Path(out_dir))))
    try:
        scenario = write_scenario(in_situ_scenario(scene), staging / XOSC_NAME)
        _place_road(road.xodr, staging / ROAD_NAME)
        if settings.external_ego:
            hero = next(p for p in choice.record if p.name == HERO)
            write_text_atomic(staging / HERO_REFERENCE_NAME,
                              reference_csv(hero.t, hero.x, hero.y, hero.heading))
        written = time.perf_counter()
        result = InSituResult(folder, folder / XOSC_NAME, choice)
        if settings.replay:
            result.verdict, played = _play_and_judge(scenario, road.xodr, choice, settings,
                                                     staging)
            result.timings_s.update(played)
        write_json_atomic(staging / IN_SITU_CHOICE_NAME, {**choice.to_dict(),
                                                  **scenario_summary(scene)})
        _publish(staging, folder)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    result.folder = folder
    result.timings_s.update({"write": round(written - started, 4),
                             "total": round(time.perf_counter() - started, 4)})
    return result


def _play_and_judge(scenario: Path, road: Path, choice: InSituChoice,
                    settings: InSituSettings,
                    staging: Path) -> tuple[InSituVerdict, dict[str, float]]:
    """Play the staged scenario on the whole road (a trajectory's reach cannot be bounded, so
    the player's map cut would only cost the time to find that out) at the recording's step,
    judge it, and keep the playback and the verdict beside it; also the seconds of the
    replay and of esmini's own work in it (loading and stepping)."""
    from scenweave import player  # loads esmini's bindings only when asked to play

    replay = player.ReplaySettings(time_step_s=choice.step_s, wall_time_s=settings.wall_time_s,
                                   default_duration_s=choice.end_s - choice.start_s,
                                   cut_map=False)
    playback = player.replay_file(scenario, road, replay)
    skip = {HERO} if settings.external_ego else set()
    verdict = judge_in_situ(playback, choice.record, skip)
    verdict.findings[:0] = xsd_findings(etree.parse(str(scenario)))
    playback.write(staging / REPLAY_NAME)
    write_json_atomic(staging / IN_SITU_VERDICT_NAME, {**verdict.to_dict(),
                                             "timings_s": playback.timings_s})
    timings = playback.timings_s
    return verdict, {"replay": float(timings.get("total", 0.0)),
                     "esmini": float(timings.get("load", 0.0) + timings.get("step", 0.0))}


def _made(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _place_road(road: Path, target: Path) -> None:
    """The road beside the scenario: a hard link to the cached file where the file system
    allows, else a copy."""
    try:
        os.link(road, target)
    except OSError:
        shutil.copyfile(road, target)
        os.chmod(target, 0o644)


def _publish(staging: Path, folder: Path) -> None:
    """Put the staged folder in place of ``folder`` (replacing an older one)."""
    os.chmod(staging, 0o755)
    old = None
    if folder.exists():
        old = folder.with_name(f".{folder.name}.old-{os.getpid()}")
        os.replace(folder, old)
    os.replace(staging, folder)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def road_of(source: str | Path, cache_dir: Path) -> RecordedRoad:
    """The recording's road (``mining.recorded_road.road_for``: converted once per file
    content, cached in ``cache_dir``) with its lights' signal ids; a road that cannot be
    converted refuses the in-situ scenarios of the file (:class:`InSituRefused`, naming the
    file and the lanelet)."""
    from scenweave.mining.recorded_road import road_for

    try:
        road = road_for(Path(source), cache_dir)
    except InputError as err:
        raise InSituRefused(str(err)) from err
    return RecordedRoad(road.xodr, {light.light_id: tuple(light.signal_ids)
                                    for light in road.lights})


@dataclass
class InSituBatch:
    """What ``write_in_situ_records`` wrote and refused (one line each)."""

    written: list[InSituResult] = field(default_factory=list)
    refused: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        def entry(result: InSituResult) -> dict[str, Any]:
            verdict = result.verdict
            judged = {} if verdict is None else {
                "passed": verdict.passed,
                "position_share": round(verdict.overall.position_share, 5),
                "worst_position_m": round(verdict.overall.worst_position_m, 4),
                "errors": sorted({f.code for f in verdict.findings if f.severity == "error"})}
            return {"folder": str(result.folder), "vehicles": len(result.choice.vehicles),
                    **judged}

        return {"written": [entry(r) for r in self.written], "refused": self.refused}


def recording_with_road(source: str, cache_dir: Path) -> tuple[Recording, RecordedRoad]:
    """The recording a mined record names (``provenance.file``) and its road; refused
    (:class:`InSituRefused`, naming the file) when there is no track to play or no road."""
    from scenweave.mining.readers import read_file

    if not source:
        raise InSituRefused("?: no recording to play in situ (no provenance file)")
    recording = read_file(Path(source))
    if not recording.tracks:
        why = "; ".join(recording.warnings) or "no track"
        raise InSituRefused(f"{source}: no recording to play in situ ({why})")
    return recording, road_of(source, cache_dir)


def write_in_situ_records(records: Iterable[Mapping[str, Any]], out_dir: Path, cache_dir: Path,
                          settings: InSituSettings | None = None) -> InSituBatch:
    """The in-situ scenario of every mined record, each in ``<out_dir>/<scenario_id>/``, with
    ``in_situ_report.json`` beside them. Each recording is read again and its road converted
    once (cached in ``cache_dir``); a record that cannot be played in situ is one refused line
    naming its scenario, the file and the track or lanelet, and the batch goes on."""
    batch = InSituBatch()
    by_file: dict[str, list[Mapping[str, Any]]] = {}
    for record in records:
        source = str((record.get("provenance") or {}).get("file", ""))
        by_file.setdefault(source, []).append(record)
    for source, mined in by_file.items():
        try:
            recording, road = recording_with_road(source, cache_dir)
        except REFUSED_ERRORS as err:
            batch.refused += [f"{r.get('scenario_id', '?')}: {refusal(err, source)}"
                              for r in mined]
            continue
        for record in mined:
            scenario_id = str(record.get("scenario_id", "record"))
            try:
                batch.written.append(write_in_situ(recording, record, out_dir, road, settings,
                                                   name=scenario_id))
            except REFUSED_ERRORS as err:
                batch.refused.append(f"{scenario_id}: {refusal(err, source)}")
    write_json_atomic(Path(out_dir) / IN_SITU_REPORT_NAME, batch.to_dict())
    return batch

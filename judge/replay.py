"""What the replay must show: a played scenario (``player.Playback``) against its params.

The XML read-back (``judge.fidelity``) proves the numbers are in the file; this proves a
real OpenSCENARIO engine does with them what the record did. Every check is a ``REPLAY_*``
finding whose message says what happened, when, and what the record says; the conventions
it rests on (where a gap is measured, which time counts) are in docs/scenario-conventions.md
under "Replay".
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from scenweave.judge.fidelity import class_of, expected_speed_changes, placed_actors
from scenweave.judge.findings import Finding
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.scenario_lib.kinematics import GAP_TOL_M, STOP_LINE_MARGIN_M
from scenweave.scenario_lib.lateral import RecordedLaneChange, recorded_lane_change
from scenweave.scenario_lib.phases import hardest_second
from scenweave.scenario_lib.vehicles import BOX_CENTRE_AHEAD
from scenweave.schemas.params import Params, actor_value, all_finite, finite
from scenweave.schemas.scenario_folder import ReplayVerdict, Tolerances, VerdictMark

if TYPE_CHECKING:  # the player loads esmini's bindings: only the type is needed here
    from scenweave.player.playback import Playback

#: a speed of the replay may differ this much from the record (m/s)
SPEED_TOL_MS = 0.5
#: a change may start this much later than scripted (s): events fire on the first step past
#: their time, and a speed change is seen once it has moved the speed by ONSET_MS
ONSET_TOL_S = 0.3
ONSET_MS = 0.2
#: a lane change may take this much longer or shorter than recorded (s, and relative)
LANE_CHANGE_TOL_S = 0.5
LANE_CHANGE_TOL_REL = 0.2
#: the offset from the lane centre jumps at least this much when a car crosses a lane line (m)
LANE_JUMP_M = 1.0
#: a vehicle further than this from its lane's centre at t = 0 is off its lane (m)
OFF_LANE_M = 1.0
#: a vehicle whose heading differs more from its lane's traffic is facing the wrong way (rad)
WRONG_WAY_RAD = math.radians(45)
#: the ego counts as stopped below this speed (m/s)
STOPPED_MS = 0.1
#: the right turn turns at least this much (rad, clockwise)
RIGHT_TURN_MIN_RAD = math.radians(45)
#: by the exit point, the ego has turned as much as the right movement, to this much (rad)
TURN_HEADING_TOL_RAD = math.radians(20)
#: the turning ego passes this close to the spawn stage's exit point (m)
TURN_EXIT_REACH_M = 3.0
#: a record with series (mined) is compared at every recorded sample: each actor's speed may
#: differ this much (m/s; osc-validation's limit for esmini replays), each gap's change since
#: the first sample this much (m), a lane change's start and end this much (s)
SERIES_SPEED_TOL_MS = 0.75
SERIES_GAP_TOL_M = 1.0
SERIES_LANE_CHANGE_TOL_S = 0.3
#: ... and a lane change timed from the record (mined, ``scenario_lib.lateral``): the played
#: crossing of the line this far from the recorded one (s), where the changer starts across
#: its lane this far from where it was recorded (m)
SERIES_CROSSING_TOL_S = 0.3
SERIES_OFFSET_TOL_M = 0.3
#: a recorded brake: at least this much speed lost within one second (m/s; mining's
#: threshold); its hardest second is reported against the played one, not judged
BRAKE_PEAK_MIN_MS = 2.0
#: the record's roles (series keys ``<role>_speed_ms``, ``<role>_gap_m``) as scenario entities
ROLE_ENTITIES = {"ego": "hero", "npc": "npc", "center": "npc_center", "right": "npc_right",
                 "left": "npc_left"}


#: a map file as ``roads`` takes it (None: the bundled Town04)
MapPath = str | Path | None
#: (road id, lane id, s) of a lane position
LanePosition = tuple[int | str, int, float]


#: the tolerances a verdict names, for whoever draws it
TOLERANCES: Tolerances = {"speed_ms": SPEED_TOL_MS, "gap_m": GAP_TOL_M,
                          "series_speed_ms": SERIES_SPEED_TOL_MS,
                          "series_gap_m": SERIES_GAP_TOL_M, "lane_change_s": LANE_CHANGE_TOL_S}


def _finding(code: str, message: str, time_s: float | None = None) -> Finding:
    when = "" if time_s is None else f"at {time_s:.2f} s: "
    return Finding(code, when + message, time_s=time_s)


@dataclass
class _Judge:
    playback: Playback
    params: Params
    doc: ScenarioDoc
    map_path: MapPath
    found: list[Finding]
    #: what the judge expected of the replay, beside what it saw (the verdict's marks)
    speed_marks: list[VerdictMark] = field(default_factory=list)
    gap_marks: list[VerdictMark] = field(default_factory=list)

    def fail(self, code: str, message: str, time_s: float | None = None) -> None:
        self.found.append(_finding(code, message, time_s))

    def verdict(self) -> ReplayVerdict:
        """The findings and the expectations, as ``verdict.json`` holds them."""
        return verdict_of(self.found, self.playback, self.speed_marks, self.gap_marks)

    def speed(self, entity: str, time_s: float) -> float:
        return self.playback.value(entity, "speed", time_s)

    @property
    def time_step_s(self) -> float:
        times = self.playback.times
        return times[1] - times[0] if len(times) > 1 else 0.0


def verdict_of(found: list[Finding], playback: Playback,
               speed_marks: Iterable[VerdictMark] = (),
               gap_marks: Iterable[VerdictMark] = ()) -> ReplayVerdict:
    """The verdict on ``playback``: the findings, each with its time, and what the judge
    expected of it (none when only collisions were judged)."""
    return {"passed": not found, "codes": sorted(set(replay_codes(found))),
            "findings": [{"code": f.code, "message": f.message, "t": f.time_s} for f in found],
            "speed_marks": list(speed_marks), "gap_marks": list(gap_marks),
            "tolerances": TOLERANCES, "series_errors": dict(playback.series_errors or {})}


def judge_replay(playback: Playback, params: Params, doc: ScenarioDoc,
                 map_path: MapPath = None) -> list[Finding]:
    """REPLAY_* findings of one playback against the params the scenario was made from."""
    return _judged(playback, params, doc, map_path).found


def replay_verdict(playback: Playback, params: Params, doc: ScenarioDoc,
                   map_path: MapPath = None) -> tuple[list[Finding], ReplayVerdict]:
    """The findings of ``judge_replay`` and the verdict written beside the replay: each
    finding with its time, each value the judge expected with what the replay showed."""
    judge = _judged(playback, params, doc, map_path)
    return judge.found, judge.verdict()


def _judged(playback: Playback, params: Params, doc: ScenarioDoc,
            map_path: MapPath) -> _Judge:
    judge = _Judge(playback, params, doc, map_path, [])
    if playback.engine_error:
        judge.fail("REPLAY_ENGINE", f"esmini could not play the scenario: {playback.engine_error}")
        return judge
    if not playback.times:
        judge.fail("REPLAY_ENGINE", "esmini recorded no step")
        return judge
    if playback.quit_by_engine:
        judge.fail("REPLAY_ENGINE", "esmini ended the scenario before its stop time",
                   playback.duration_s)
    for check in (_actors_present, _start_poses, _start_speeds, _speed_changes, _gaps,
                  _lane_changes, _events_fired, _lights, _stop_or_pass, _right_turn, _collisions,
                  _series):
        check(judge)
    return judge


def judge_collisions_only(playback: Playback) -> list[Finding]:
    """What can be judged without the record: the engine played it, and nothing collided."""
    if playback.engine_error:
        return [_finding("REPLAY_ENGINE",
                         f"esmini could not play the scenario: {playback.engine_error}")]
    return _collision_findings(playback)


# --- the checks ------------------------------------------------------------------------------

def _start_poses(judge: _Judge) -> None:
    """Every vehicle starts on a driving lane, on its centre, facing its traffic.

    The lane is the one the spawn stage chose (``<prefix>_road_id/_lane_id/_s``) where params
    name it: inside a junction, connecting roads overlap and esmini may report any of them.
    Otherwise it is the lane esmini found the vehicle on.
    """
    from scenweave import roads

    network = roads.road_network(judge.map_path)
    planned = {entity: prefix for entity, prefix in placed_actors(judge.params)}
    for entity in judge.playback.entities:
        track = judge.playback.tracks[entity]
        lane = _planned_lane(judge.params, planned.get(entity)) or \
            (int(track["road"][0]), int(track["lane"][0]), track["s"][0])
        try:
            pose = network.lane_to_world(*lane)
            drivable = network.is_drivable(*lane)
        except roads.RoadError:
            judge.fail("REPLAY_OFF_LANE", f"{entity} starts on road {lane[0]} lane {lane[1]}, "
                       "which is not a lane of the map", 0.0)
            continue
        # a car recorded off its lane's centre (mid-change) starts as far off it
        intended = finite(actor_value(judge.params, planned.get(entity) or "", "lane_offset_m"))
        off = math.hypot(track["x"][0] - pose.x, track["y"][0] - pose.y) - abs(intended or 0.0)
        turned = math.remainder(track["h"][0] - pose.h, math.tau)
        where = f"(road {lane[0]}, lane {lane[1]})"
        if not drivable:
            judge.fail("REPLAY_OFF_LANE", f"{entity} starts on a lane that is not a driving lane "
                       f"{where}", 0.0)
        elif off > OFF_LANE_M:
            judge.fail("REPLAY_OFF_LANE", f"{entity} starts {off:.1f} m from the centre of its "
                       f"lane {where}", 0.0)
        elif abs(turned) > WRONG_WAY_RAD:
            judge.fail("REPLAY_WRONG_WAY", f"{entity} starts facing {math.degrees(turned):.0f} "
                       f"deg off its lane's direction of traffic {where}", 0.0)


def _planned_lane(params: Params, prefix: str | None) -> LanePosition | None:
    """The lane position the spawn stage chose for ``prefix``, None when params lack it."""
    if prefix is None:
        return None
    road, lane = actor_value(params, prefix, "road_id"), actor_value(params, prefix, "lane_id")
    s = actor_value(params, prefix, "s")
    return None if road is None or lane is None or s is None else (road, lane, s)


def _actors_present(judge: _Judge) -> None:
    """Every vehicle the record had is in the replay."""
    for entity, _ in placed_actors(judge.params):
        if entity not in judge.playback.tracks:
            judge.fail("REPLAY_ACTOR_MISSING", f"{entity} of the record is not in the scenario")


def _start_speeds(judge: _Judge) -> None:
    for entity, prefix in placed_actors(judge.params):
        want = finite(actor_value(judge.params, prefix, "speed_ms"))
        if want is None:
            continue
        got = judge.playback.tracks[entity]["speed"][0] \
            if entity in judge.playback.tracks else None
        judge.speed_marks.append(_mark(entity, "start speed", 0.0, want, got, SPEED_TOL_MS))
        if got is not None and abs(got - want) > SPEED_TOL_MS:
            judge.fail("REPLAY_START_SPEED", f"{entity} starts at {got:.2f} m/s, the record "
                       f"says {want:.2f} m/s", 0.0)


def _speed_changes(judge: _Judge) -> None:
    """Each scripted speed change starts on time and reaches its target in its duration."""
    for name, target, duration, start in expected_speed_changes(judge.doc, judge.params):
        entity = name.removesuffix("_speed_change")
        if target is None or duration is None or start is None:
            continue
        # events fire on the first step past their time: the change ends one step late, and
        # the next one (keeping the distance after the record) may start right then
        ends = start + duration + judge.time_step_s
        compared = entity in judge.playback.tracks and ends <= judge.playback.duration_s \
            and not _has_speed_series(judge.params, entity)  # a series: compared in _series
        got = judge.speed(entity, ends) if compared else None
        judge.speed_marks.append(_mark(entity, "target speed", start + duration, target, got,
                                       SPEED_TOL_MS))
        if got is None:
            continue  # absent, a recorded curve, or the scenario stops before the change ends
        v0 = judge.speed(entity, start)
        if abs(got - target) > SPEED_TOL_MS:
            judge.fail("REPLAY_SPEED", f"{entity} drives {got:.2f} m/s at the end of its speed "
                       f"change ({name}), the record says {target:.2f} m/s", ends)
        if abs(target - v0) <= 2 * ONSET_MS or not name.endswith("_speed_change"):
            continue  # a later phase starts from a change still under way: no onset to see
        # a linear change moves the speed by ONSET_MS this long after it starts
        seen_after = duration * ONSET_MS / abs(target - v0) if duration > 0 else 0.0
        onset = _first_time(judge.playback, entity, start - 0.5, _differs_from(v0, ONSET_MS))
        if onset is None or not start - 0.1 <= onset - seen_after <= start + ONSET_TOL_S:
            judge.fail("REPLAY_SPEED_ONSET", f"{entity}'s speed change ({name}) "
                       + ("never starts" if onset is None else
                          f"starts at {onset - seen_after:.2f} s")
                       + f", scripted for {start:.2f} s", onset)


def _gaps(judge: _Judge) -> None:
    """The recorded gap holds at the manoeuvre start (and, for FL, ``duration_s`` later)."""
    params = judge.params
    start = finite(params.get("maneuver_start_s"))
    wanted = [(entity, "gap", finite(actor_value(params, prefix, "distance_m")), start)
              for entity, prefix in placed_actors(params) if entity != "hero"]
    # a record with a gap series is judged at every sample (_series), which leaves out what
    # the record names tracking noise; its end gap, a field measured through that noise, not
    if class_of(params).gap_at_end and start is not None and not _has_gap_series(params):
        wanted.append(("npc", "gap at end", finite(params.get("npc_distance_end_m")),
                       start + (finite(params.get("duration_s")) or 0.0)))
    for entity, what, gap, at_s in wanted:
        if gap is None or at_s is None or params.get("domain") != "highway":
            continue
        compared = entity in judge.playback.tracks and at_s <= judge.playback.duration_s
        got = gap_along_lane(judge.playback, entity, at_s, judge.map_path) if compared else None
        judge.gap_marks.append(_mark(entity, what, at_s, gap, got, GAP_TOL_M))
        if not compared:
            continue
        if got is None:
            judge.fail("REPLAY_GAP", f"{entity}'s gap to the ego could not be measured along its "
                       "lane (not on the ego's road or a neighbour lane)", at_s)
        elif abs(got - gap) > GAP_TOL_M:
            judge.fail("REPLAY_GAP", f"{entity} is {got:.2f} m from the ego along its lane, the "
                       f"record says {gap:.2f} m", at_s)


def _mark(entity: str, what: str, t: float, expected: float, observed: float | None,
          tol: float) -> VerdictMark:
    return {"entity": entity, "what": what, "t": round(t, 4), "expected": expected,
            "observed": None if observed is None else round(observed, 4), "tol": tol}


def _lane_changes(judge: _Judge) -> None:
    params = judge.params
    maneuver = class_of(params)
    actor = maneuver.lane_change
    timing = all_finite(params.get("maneuver_start_s"), params.get("duration_s"))
    if actor is None or actor not in judge.playback.tracks or timing is None:
        return
    _, duration = timing
    changes = lane_changes(judge.playback, actor)
    direction = params.get("lane_change_direction")
    if len(changes) != 1:
        judge.fail("REPLAY_LANE_CHANGE", f"{actor} changes lanes {len(changes)} times "
                   f"({', '.join(f'{side} at {t:.2f} s' for t, side in changes) or 'never'}), the "
                   f"record has one change to the {direction}")
        return
    crossed_s, side = changes[0]
    if side != direction:
        judge.fail("REPLAY_LANE_CHANGE", f"{actor} changes lanes to the {side}, the record "
                   f"says {direction}", crossed_s)
    took = None if _timed_change(params, actor) is not None \
        else lane_change_duration(judge.playback, actor, crossed_s)  # timed: in the series
    if took is not None and abs(took - duration) > max(LANE_CHANGE_TOL_S,
                                                       LANE_CHANGE_TOL_REL * duration):
        judge.fail("REPLAY_LANE_CHANGE", f"{actor}'s lane change takes {took:.2f} s, the record "
                   f"says {duration:.2f} s", crossed_s)
    cut_in = maneuver.npc_ends_in_ego_lane
    if actor == "npc" and cut_in is not None:
        end = judge.playback.duration_s
        same = _same_lane(judge.playback, "npc", "hero", end, judge.map_path)
        if same is not None and same != cut_in:
            judge.fail("REPLAY_LANE_CHANGE", "the NPC ends " + ("in" if same else "out of")
                       + " the ego's lane; a " + ("cut-in" if cut_in else "cut-out")
                       + " ends " + ("in it" if cut_in else "out of it"), end)


def _events_fired(judge: _Judge) -> None:
    fired = judge.playback.fired("action")
    for name, event in judge.doc.events.items():
        if event.start_s is None or event.start_s >= judge.playback.duration_s:
            continue
        if name not in fired:
            judge.fail("REPLAY_EVENT", f"action {name!r} (scripted for {event.start_s:.2f} s) "
                       "never started")
        elif fired[name] > event.start_s + ONSET_TOL_S:
            judge.fail("REPLAY_EVENT", f"action {name!r} started at {fired[name]:.2f} s, "
                       f"scripted for {event.start_s:.2f} s", fired[name])


def _lights(judge: _Judge) -> None:
    """The light shows what the class needs when the ego reaches the stop line (or stops)."""
    params = judge.params
    stop_line = finite(params.get("spawn_stop_line_distance_m"))
    if not judge.playback.lights or stop_line is None:
        return
    reached = crosses_stop_line_s(judge.playback, stop_line, judge.doc.vehicle_length("hero"))
    if class_of(params).stops_at_line:
        stopped = _first_time(judge.playback, "hero", 0.0, lambda v: v < STOPPED_MS)
        colour = light_state(judge.playback, stopped if stopped is not None else
                             judge.playback.duration_s)
        if colour not in ("yellow", "red"):
            judge.fail("REPLAY_LIGHT", f"the light is {colour} when the ego stops; a stop at "
                       "red happens on yellow or red", stopped)
        ego_speed = finite(params.get("ego_speed_ms"))
        if ego_speed is not None:  # braking: ONSET_MS slower than the record's start speed
            braking_below = ego_speed - ONSET_MS
            early = _first_time(judge.playback, "hero", 0.0, lambda v: v < braking_below)
            if early is not None and light_state(judge.playback, early) == "green":
                judge.fail("REPLAY_LIGHT", "the ego brakes while its light is green", early)
    elif reached is not None:
        colour = light_state(judge.playback, reached)
        allowed = {"green", "yellow"} if params.get("tfl_state") == "orange" else {"green"}
        if colour not in allowed:
            judge.fail("REPLAY_LIGHT", f"the light is {colour} when the ego reaches the stop "
                       f"line; the record passes on {params.get('tfl_state') or 'green'}",
                       reached)


def _stop_or_pass(judge: _Judge) -> None:
    params = judge.params
    maneuver, stop_line = class_of(params), finite(params.get("spawn_stop_line_distance_m"))
    if params.get("domain") != "urban" or maneuver.light is None or stop_line is None:
        return
    if maneuver.stops_at_line:
        stopped = _first_time(judge.playback, "hero", 0.0, lambda v: v < STOPPED_MS)
        if stopped is None:
            judge.fail("REPLAY_NO_STOP", f"the ego never stops (record: it stops before the "
                       f"stop line {stop_line:.1f} m ahead)")
            return
        driven = travelled(judge.playback, "hero", judge.playback.duration_s)
        if driven > stop_line + 0.05:
            judge.fail("REPLAY_STOP_PAST_LINE", f"the ego comes to rest {driven:.2f} m from its "
                       f"start, past the stop line at {stop_line:.2f} m", stopped)
        elif driven < stop_line - STOP_LINE_MARGIN_M - 5.0:
            judge.fail("REPLAY_STOP_PAST_LINE", f"the ego stops {stop_line - driven:.1f} m before "
                       "the stop line; the record stops at it", stopped)
    elif crosses_stop_line_s(judge.playback, stop_line,
                             judge.doc.vehicle_length("hero")) is None:
        driven = travelled(judge.playback, "hero", judge.playback.duration_s)
        judge.fail("REPLAY_NO_PASS", f"the ego's front never crosses the stop line "
                   f"{stop_line:.1f} m ahead of its spawn (its rear axle drove {driven:.1f} m); "
                   "the record passes")


def crosses_stop_line_s(playback: Playback, stop_line_m: float,
                        length_m: float | None) -> float | None:
    """When the ego passes the stop line ``stop_line_m`` ahead of its spawn: when its front
    bumper crosses it (``length_m``: its box; the spawn is its reference point, the rear
    axle), as mining reads a pass. A car that passes on orange and then nearly stops just
    past the line (0.3 m/s, its rear axle still short of it) has passed (issue 36); ``None``
    when the front never gets there."""
    front = 0.0 if length_m is None else length_m * (BOX_CENTRE_AHEAD + 0.5)
    return _time_travelled(playback, "hero", max(stop_line_m - front, 0.0))


def _right_turn(judge: _Judge) -> None:
    """A right turn (U4_4) reaches the exit the spawn stage found for the junction's right
    movement, turned the way that movement turns (roads may bend on afterwards); without the
    exit in params, the whole drive must turn right."""
    params = judge.params
    if class_of(params).turn != "right":
        return
    track = judge.playback.tracks["hero"]
    exit_pose = all_finite(actor_value(params, "turn_exit", "x"),
                           actor_value(params, "turn_exit", "y"),
                           actor_value(params, "turn_exit", "h"))
    if exit_pose is None:
        turned = heading_change(judge.playback, "hero")
        if turned > -RIGHT_TURN_MIN_RAD:
            judge.fail("REPLAY_TURN", f"the ego turns {math.degrees(turned):+.0f} deg (right "
                       "turns are negative); the record turns right")
        return
    distances = [math.dist(exit_pose[:2], p) for p in zip(track["x"], track["y"], strict=True)]
    nearest = min(range(len(distances)), key=distances.__getitem__)
    if distances[nearest] > TURN_EXIT_REACH_M:
        judge.fail("REPLAY_TURN", f"the ego passes {distances[nearest]:.1f} m from the right "
                   "turn's exit lane at its nearest")
        return
    turned = heading_change(judge.playback, "hero", until=nearest)
    movement = math.remainder(exit_pose[2] - track["h"][0], math.tau)
    if abs(turned - movement) > TURN_HEADING_TOL_RAD:
        judge.fail("REPLAY_TURN", f"the ego has turned {math.degrees(turned):+.0f} deg when it "
                   f"reaches the exit lane; the right movement turns "
                   f"{math.degrees(movement):+.0f} deg", judge.playback.times[nearest])


def _collisions(judge: _Judge) -> None:
    judge.found += _collision_findings(judge.playback)


def _collision_findings(playback: Playback) -> list[Finding]:
    """One REPLAY_COLLISION per pair of entities that collide, at the first time."""
    seen: set[tuple[str, str]] = set()
    found = []
    for time_s, a, b in playback.collisions:
        if (a, b) not in seen:
            seen.add((a, b))
            found.append(_finding("REPLAY_COLLISION",
                                  f"{a} and {b} collide; the record has no collision", time_s))
    return found


def _has_gap_series(params: Params) -> bool:
    series = params.get("recorded_series")
    return isinstance(series, dict) and bool(series.get("npc_gap_m"))


def _has_speed_series(params: Params, entity: str) -> bool:
    series = params.get("recorded_series")
    role = {e: r for r, e in ROLE_ENTITIES.items()}.get(entity)
    return isinstance(series, dict) and role is not None and bool(series.get(f"{role}_speed_ms"))


@dataclass
class SeriesError:
    """How far one played quantity is from the record over its samples."""

    entity: str
    quantity: str
    unit: str
    #: (scenario time, recorded, played) per compared sample
    samples: list[tuple[float, float, float]]

    @property
    def worst(self) -> tuple[float, float, float]:
        return max(self.samples, key=lambda s: abs(s[2] - s[1]))

    def summary(self) -> dict[str, float | int]:
        errors = [abs(got - want) for _, want, got in self.samples]
        return {"max": round(max(errors), 4),
                "rms": round(math.sqrt(sum(e * e for e in errors) / len(errors)), 4),
                "samples": len(errors), "worst_at_s": round(self.worst[0], 3)}


def series_errors(playback: Playback, params: Params) -> list[SeriesError]:
    """Each actor's played speed and gap change against the record's series at every recorded
    sample (scenario time = ``maneuver_start_s`` + the series' ``t``), and a lane change's
    played start and end against the record's; empty without series."""
    series, start = params.get("recorded_series"), finite(params.get("maneuver_start_s"))
    if not isinstance(series, dict) or start is None or not playback.times:
        return []
    times = series.get("t") or []
    found = []
    for role, entity in ROLE_ENTITIES.items():
        if entity not in playback.tracks:
            continue
        speeds = [(start + t, v) for t, v in recorded_speeds(series, role)
                  if start + t <= playback.duration_s]
        if speeds:
            found.append(SeriesError(entity, "speed", "m/s", [
                (at, want, playback.value(entity, "speed", at)) for at, want in speeds]))
        # a recorded gap of 0 means side by side (no facing bumpers): not a distance
        gaps = [(start + t, g) for t, g in zip(times, series.get(f"{role}_gap_m") or (),
                                               strict=False)
                if role != "ego" and t is not None and g is not None and g != 0
                and start + t <= playback.duration_s]
        runs = _noise_free_runs(gaps, series, ("ego", role), start)
        if runs and "hero" in playback.tracks:
            found.append(SeriesError(entity, "gap change", "m", [
                sample for part in runs for run in _same_bumpers(part)
                for sample in _gap_changes(playback, entity, run)]))
    found += _lane_change_timing(playback, params)
    return found


def _noise_free_runs(gaps: list[tuple[float, float]], series: dict[str, list[float | None]],
                     roles: tuple[str, ...], start: float) -> list[list[tuple[float, float]]]:
    """The recorded gaps in runs between samples of tracking noise of ``roles``
    (``<role>_noise``), which are left out: past such a stretch the positions, and the gap
    measured from them, may stay off by what the tracker's box moved, so each run's change
    is measured from its own first sample."""
    times = series.get("t") or []
    noisy = sorted(start + t for role in roles
                   for t, n in zip(times, series.get(f"{role}_noise") or (), strict=False)
                   if n and t is not None)
    runs: list[list[tuple[float, float]]] = []
    for sample in gaps:
        if any(abs(sample[0] - at) < 1e-6 for at in noisy):
            continue
        broken = bool(runs) and any(runs[-1][-1][0] < at < sample[0] for at in noisy)
        if runs and not broken:
            runs[-1].append(sample)
        else:
            runs.append([sample])
    return runs


def _same_bumpers(gaps: list[tuple[float, float]]) -> list[list[tuple[float, float]]]:
    """The samples in runs of one sign: when a car passes alongside, the facing bumpers
    change (ahead: its rear and the ego's front; behind: the other two), so the bumper gap
    jumps by both cars' lengths; each run's change is measured from its own first sample."""
    runs: list[list[tuple[float, float]]] = []
    for sample in gaps:
        if runs and (runs[-1][-1][1] > 0) == (sample[1] > 0):
            runs[-1].append(sample)
        else:
            runs.append([sample])
    return runs


def _gap_changes(playback: Playback, entity: str,
                 gaps: list[tuple[float, float]]) -> list[tuple[float, float, float]]:
    """The recorded gap's change since its first sample against the played one: what
    ``entity`` drove minus what the ego drove meanwhile (both along their lanes)."""
    first_at, first_gap = gaps[0]
    base = travelled(playback, entity, first_at) - travelled(playback, "hero", first_at)
    return [(at, gap - first_gap, travelled(playback, entity, at)
             - travelled(playback, "hero", at) - base) for at, gap in gaps]


def _lane_change_timing(playback: Playback, params: Params) -> list[SeriesError]:
    """The recorded lane change runs from ``maneuver_start_s`` for ``duration_s`` (mined:
    measured from the lateral motion); the played one from leaving the old lane's centre to
    settling in the new one's."""
    actor = class_of(params).lane_change
    timing = all_finite(params.get("maneuver_start_s"), params.get("duration_s"))
    if actor is None or actor not in playback.tracks or timing is None:
        return []
    start, duration = timing
    changes = lane_changes(playback, actor)
    if len(changes) != 1:
        return []  # _lane_changes names it
    began, ended = lane_change_span(playback, actor, changes[0][0])
    end = SeriesError(actor, "lane change end", "s", [(start + duration, start + duration,
                                                       ended or playback.duration_s)])
    timed = _timed_change(params, actor)
    if timed is None:
        return [SeriesError(actor, "lane change start", "s", [(start, start, began)]), end]
    # timed from the record: it starts where it was recorded, off its lane's centre or not,
    # and crosses the line when it did (its start is where it starts, not a time)
    return [SeriesError(actor, "lane change crossing", "s",
                        [(timed.cross_s, timed.cross_s, changes[0][0])]),
            SeriesError(actor, "lateral offset at start", "m",
                        [(start, timed.offset_toward_m, _offset_toward(playback, actor, start,
                                                                       params))]), end]


def _timed_change(params: Params, actor: str) -> RecordedLaneChange | None:
    """The lane change of ``actor`` (``hero``/``npc``) as the record timed it, if it did."""
    return recorded_lane_change(params, "ego" if actor == "hero" else "npc")


def _offset_toward(playback: Playback, entity: str, time_s: float, params: Params) -> float:
    """How far ``entity`` is off its lane's centre toward the lane it changes to (m)."""
    i = playback.index_at(time_s)
    track = playback.tracks[entity]
    left = track["lane_offset"][i] * (1 if track["lane"][i] < 0 else -1)
    return left if params.get("lane_change_direction") == "left" else -left


def recorded_speeds(series: dict[str, list[float | None]],
                    role: str) -> list[tuple[float, float]]:
    """``(t, speed)`` the replay is judged against: the speed from the recorded positions
    (``<role>_speed_raw_ms``, mining's 0.5 s average, not the series fitted to) where the
    record has it, else ``<role>_speed_ms``; samples the record names tracking noise
    (``<role>_noise``) are left out: no car drove them."""
    times = series.get("t") or []
    speeds = series.get(f"{role}_speed_raw_ms") or series.get(f"{role}_speed_ms") or ()
    noise = series.get(f"{role}_noise") or [None] * len(times)
    return [(t, v) for t, v, n in zip(times, speeds, noise, strict=False)
            if t is not None and v is not None and not n]


def brake_peaks(playback: Playback, params: Params) -> dict[str, dict[str, float | int]]:
    """Each actor's hardest second of braking in the replay against the record's (its
    raw-position speed, at the recorded samples), where the record brakes (at least
    :data:`BRAKE_PEAK_MIN_MS` lost within a second): reported per scenario
    (``replay.json`` ``series_errors["<entity> brake peak"]``), not judged."""
    series, start = params.get("recorded_series"), finite(params.get("maneuver_start_s"))
    if not isinstance(series, dict) or start is None or not playback.times:
        return {}
    found: dict[str, dict[str, float | int]] = {}
    for role, entity in ROLE_ENTITIES.items():
        samples = [(start + t, v) for t, v in recorded_speeds(series, role)
                   if start + t <= playback.duration_s]
        if entity not in playback.tracks or len(samples) < 2:
            continue
        times = [t for t, _ in samples]
        want = hardest_second(times, [v for _, v in samples])
        if want < BRAKE_PEAK_MIN_MS:
            continue
        got = hardest_second(times, [playback.value(entity, "speed", t) for t in times])
        found[f"{entity} brake peak"] = {
            "max": round(abs(got - want), 4), "rms": round(abs(got - want), 4),
            "samples": len(times), "worst_at_s": round(times[0], 3),
            "recorded_ms2": round(want, 4), "played_ms2": round(got, 4),
            "share": round((got - want) / want, 4)}
    return found


def _series(judge: _Judge) -> None:
    """REPLAY_SERIES: the whole recorded motion, sample by sample (records with series)."""
    tolerance = {"speed": SERIES_SPEED_TOL_MS, "gap change": SERIES_GAP_TOL_M,
                 "lane change start": SERIES_LANE_CHANGE_TOL_S,
                 "lane change end": SERIES_LANE_CHANGE_TOL_S,
                 "lane change crossing": SERIES_CROSSING_TOL_S,
                 "lateral offset at start": SERIES_OFFSET_TOL_M}
    errors = series_errors(judge.playback, judge.params)
    summary: dict[str, dict[str, float | int]] = {}
    for error in errors:
        summary[f"{error.entity} {error.quantity}"] = error.summary()
        at, want, got = error.worst
        if abs(got - want) > tolerance[error.quantity]:
            judge.fail("REPLAY_SERIES", f"{error.entity}'s {error.quantity} is {got:.2f} "
                       f"{error.unit}, the record says {want:.2f} {error.unit} (tolerance "
                       f"{tolerance[error.quantity]:g} {error.unit}; "
                       f"{error.summary()['samples']} samples compared)", at)
    summary |= brake_peaks(judge.playback, judge.params)
    if summary:
        # additive keys of replay.json (player.Playback.series_errors)
        judge.playback.series_errors = summary


# --- measurements on a playback (shared with the pictures) -----------------------------------

def gap_along_lane(playback: Playback, entity: str, time_s: float, map_path: MapPath = None,
                   ego: str = "hero") -> float | None:
    """Metres from the ego's reference point to ``entity``'s, along ``entity``'s lane, at
    ``time_s`` (positive ahead). The ego's position is carried sideways onto that lane at its
    own ``s``: the entity's lane id on a shared road, else the ego's lane or the lane beside it
    on either side (lane ids change across road ends, the chain of lanes does not)."""
    from scenweave import roads

    i = playback.index_at(time_s)
    ta, tb = playback.tracks[ego], playback.tracks[entity]
    road, s = int(ta["road"][i]), playback.value(ego, "s", time_s)
    end = (int(tb["road"][i]), int(tb["lane"][i]), playback.value(entity, "s", time_s))
    for lane in _lanes_beside(road, int(ta["lane"][i]), end[1] if end[0] == road else None, s,
                              map_path):
        try:
            along = roads.distance_along_lane(road, lane, s, *end, map_path=map_path)
        except roads.RoadError:
            along = None
        if along is not None:
            return along
    return None


def gap_series(playback: Playback, entity: str, times: Iterable[float],
               map_path: MapPath = None) -> list[float | None]:
    """``gap_along_lane`` at each of ``times``, None where it cannot be measured: for a
    picture of the replay, which shows what it can (never raises)."""
    found: list[float | None] = []
    for time_s in times:
        try:
            found.append(gap_along_lane(playback, entity, time_s, map_path))
        except Exception:  # noqa: BLE001 - a picture shows what it can measure
            found.append(None)
    return found


def _lanes_beside(road: int | str, ego_lane: int, shared_lane: int | None, s: float,
                  map_path: MapPath) -> list[int]:
    """Lane ids on the ego's road to measure from: the other's own (same road), the ego's,
    and the same-direction lanes left and right of it."""
    from scenweave import roads

    lanes = [lane for lane in (shared_lane, ego_lane) if lane]
    network = roads.road_network(map_path)
    try:
        key = network.key_at(road, ego_lane, s)
    except roads.RoadError:
        return lanes
    lanes += [n.lane_id for side in ("left", "right")
              if (n := network.neighbour(key, side)) is not None]
    return list(dict.fromkeys(lanes))


def lane_changes(playback: Playback, entity: str) -> list[tuple[float, str]]:
    """``(time, 'left'|'right')`` each time ``entity`` crosses into another lane.

    A crossing is a step where the lane id changes and the offset from the lane centre jumps
    by more than ``LANE_JUMP_M`` (it flips from one edge of the old lane to the other side of
    the new one; entering the next road keeps it continuous). Offsets are along OpenDRIVE's
    ``t`` (left of the road's direction): cars in negative lanes drive along ``s``, in positive
    lanes against it, so each is turned into the offset left of the car's own travel first;
    a jump of that toward the right is a change to the left. Turning each sample by its own
    lane keeps the offset continuous where a road meets one whose reference line runs the
    other way (lane -6 continuing as lane 6), as CARLA's Town06 highways do mid-manoeuvre.
    """
    track, found = playback.tracks[entity], []
    left_of_travel = [offset if lane < 0 else -offset
                      for offset, lane in zip(track["lane_offset"], track["lane"], strict=True)]
    for i in range(1, len(playback.times)):
        jump = left_of_travel[i] - left_of_travel[i - 1]
        if track["lane"][i] == track["lane"][i - 1] or abs(jump) < LANE_JUMP_M:
            continue
        found.append((playback.times[i], "left" if jump < 0 else "right"))
    return found


def lane_change_duration(playback: Playback, entity: str, crossed_s: float) -> float | None:
    """How long the change around ``crossed_s`` took: from leaving the old lane's centre
    (lateral offset above 0.1 m) to settling in the new one's."""
    began, ended = lane_change_span(playback, entity, crossed_s)
    return None if ended is None else ended - began


def lane_change_span(playback: Playback, entity: str,
                     crossed_s: float) -> tuple[float, float | None]:
    """When the change around ``crossed_s`` left the old lane's centre (lateral offset above
    0.1 m) and settled in the new one's (None: not before the replay ends)."""
    track, i = playback.tracks[entity], playback.index_at(crossed_s)
    begin = i - 1
    while begin > 0 and abs(track["lane_offset"][begin]) > 0.1:
        begin -= 1
    end = i
    while end < len(playback.times) - 1 and abs(track["lane_offset"][end]) > 0.1:
        end += 1
    if end == len(playback.times) - 1:
        return playback.times[begin], None
    return playback.times[begin], playback.times[end]


def travelled(playback: Playback, entity: str, time_s: float) -> float:
    """Metres ``entity`` drove from t = 0 to ``time_s`` (trapezoid over its speed)."""
    speeds, total = playback.tracks[entity]["speed"], 0.0
    for i in range(1, len(playback.times)):
        if playback.times[i] > time_s + 1e-9:
            break
        total += (speeds[i] + speeds[i - 1]) / 2 * (playback.times[i] - playback.times[i - 1])
    return total


def heading_change(playback: Playback, entity: str, until: int | None = None) -> float:
    """Total turn of ``entity`` over the replay, or up to sample ``until`` (rad,
    counter-clockwise positive)."""
    headings = playback.tracks[entity]["h"][:None if until is None else until + 1]
    return sum(math.remainder(b - a, math.tau) for a, b in zip(headings, headings[1:],
                                                                strict=False))


def light_state(playback: Playback, time_s: float) -> str | None:
    """The colour of the scenario's light at ``time_s``: the last light action started."""
    started = playback.fired("action")
    shown = [(t, playback.lights[name]) for name, t in started.items() if name in playback.lights]
    shown = [c for c in sorted(shown) if c[0] <= time_s + 1e-9]
    return shown[-1][1] if shown else None


def _time_travelled(playback: Playback, entity: str, metres: float) -> float | None:
    speeds, total = playback.tracks[entity]["speed"], 0.0
    for i in range(1, len(playback.times)):
        total += (speeds[i] + speeds[i - 1]) / 2 * (playback.times[i] - playback.times[i - 1])
        if total >= metres:
            return playback.times[i]
    return None


def _differs_from(speed: float, by: float) -> Callable[[float], bool]:
    """A test of a speed: more than ``by`` away from ``speed``."""
    return lambda v: abs(v - speed) > by


def _first_time(playback: Playback, entity: str, from_s: float,
                test: Callable[[float], bool]) -> float | None:
    speeds = playback.tracks[entity]["speed"]
    for t, v in zip(playback.times, speeds, strict=True):
        if t >= from_s - 1e-9 and test(v):
            return t
    return None


def _same_lane(playback: Playback, a: str, b: str, time_s: float,
               map_path: MapPath) -> bool | None:
    """Whether ``b`` drives in ``a``'s lane at ``time_s``: ``a``'s lane, followed along the map
    either way (across lane sections, where lane ids are renumbered, and road ends), reaches
    ``b``. None when it does not and they are on different roads (e.g. overlapping junction
    roads)."""
    from scenweave import roads

    i = playback.index_at(time_s)
    ta, tb = playback.tracks[a], playback.tracks[b]
    try:
        along = roads.distance_along_lane(int(ta["road"][i]), int(ta["lane"][i]), ta["s"][i],
                                          int(tb["road"][i]), int(tb["lane"][i]), tb["s"][i],
                                          map_path=map_path)
    except roads.RoadError:
        along = None
    if along is not None:
        return True
    return False if ta["road"][i] == tb["road"][i] else None


def replay_codes(findings: Iterable[Finding]) -> list[str]:
    return [f.code for f in findings if f.code.startswith("REPLAY")]

"""The highway classes in a recording of a whole road: braking leads (BRAKE, BR_BK), cut-ins
and cut-outs (CIN*, COUT*), the ego's own lane changes (LCF, LCB), car following (FLF, FLB)
and free rides with their surrounding cars (FRF, FRB).

Each detector looks at every track as a possible ego (the recording car of a MOOVE record) and
returns events with the fields a MOOVE file of that class gives (its layout's column names and
units: km/h, bumper gaps). Thresholds come from ``mining/thresholds.json``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from scenweave.mining.lanes import border_between, signed_distance
from scenweave.mining.motion import (
    NOISE_RETURN_S,
    best_second_deceleration,
    runs,
    trusted_steps,
)
from scenweave.mining.scene import KMH, Event, Scene, make_event, vehicle
from scenweave.mining.tracks import Floats, Mask, Steps, Track
from scenweave.mining.traffic import Neighbour

# -- braking leads (BRAKE, BR_BK) ----------------------------------------------------------

def braking_leads(scene: Scene) -> Iterator[Event]:
    """One event per braking phase of a car with a follower close behind it."""
    limits = scene.thresholds["brake"]
    window = scene.thresholds["smoothing"]["window_s"]
    for i, track in enumerate(scene.tracks):
        motion, measured = scene.motion[i], scene.positions[i]
        trusted = trusted_steps(track.t, window)
        for first, last in braking_phases(track.t, motion.speed, limits["onset_ms2"],
                                          limits["merge_within_s"], measured.noise):
            # the smoothing flattens a short brake the record's own speed shows: either counts
            # here; the record's speed decides (_brake_event)
            drop = max(float(motion.speed[first] - motion.speed[last]),
                       scene.speed_at_step(i, first) - scene.speed_at_step(i, last))
            best = max(best_second_deceleration(track.t, motion.speed, first, last, trusted),
                       best_second_deceleration(track.t, measured.speed, first, last,
                                                trusted & ~measured.noise))
            if best < limits["deceleration_ms2"] or drop < limits["min_speed_drop_ms"] \
                    or motion.speed[first] < limits["min_start_speed_ms"]:
                continue
            follower = scene.follower(i, first)
            if follower is None or follower.gap_m > limits["follower_within_m"] \
                    or not moves(scene, follower.track, float(track.t[first]),
                                 float(track.t[last]), limits["min_ego_speed_ms"]):
                continue  # nobody behind in its path, or an ego standing all along
            event = _brake_event(scene, i, follower, first, last, limits)
            if event is not None:
                yield event


def braking_phases(t: Floats, speed: Floats, onset_ms2: float, merge_within_s: float,
                   noise: Mask | None = None) -> list[tuple[int, int]]:
    """``(first, last)`` of each stretch in which the speed keeps falling (faster than
    ``onset_ms2``); stretches apart by at most ``merge_within_s`` are one braking phase, and
    so are two that only tracking noise (``noise``, bridged in ``speed``) lies between: the
    noise neither makes a phase nor cuts one."""
    if len(t) < 2:
        return []
    falling = np.gradient(speed, t) < -onset_ms2
    if noise is not None and noise.any() and not noise.all():
        clean = np.flatnonzero(~noise)
        both_sides = np.interp(np.arange(len(t)), clean, falling[clean].astype(float))
        falling = np.where(noise, both_sides >= 1.0, falling)
    phases: list[tuple[int, int]] = []
    for first, last in runs(falling):
        if phases and t[first] - t[phases[-1][1]] <= merge_within_s + 1e-6:
            phases[-1] = (phases[-1][0], last)
        else:
            phases.append((first, last))
    return phases


def moves(scene: Scene, i: int, start: float, end: float, least_ms: float) -> bool:
    """Track ``i`` drives faster than ``least_ms`` at some step from ``start`` to ``end`` (its
    speed from its positions): a class whose ego must move never takes one standing all
    along (issue 36: a standing ego's braking or cut-in plays as nothing)."""
    track = scene.tracks[i]
    inside = (track.t >= start - 1e-6) & (track.t <= end + 1e-6)
    speeds = scene.positions[i].filled[inside]
    return bool(len(speeds)) and float(np.max(speeds)) >= least_ms


def _swell_before(scene: Scene, i: int, first: int) -> float:
    """How much track ``i``'s speed rose in the :data:`NOISE_RETURN_S` before step
    ``first`` (m/s, never negative; the record's speed, noise left out): a fall that gives
    back a rise of at least half ``min_speed_drop_ms`` and ends less than that below where
    the rise began is a speed that jumped up and back (issue 32), not a brake."""
    track, speed = scene.tracks[i], scene.positions[i].fitted
    before = (track.t >= track.t[first] - NOISE_RETURN_S - 1e-6) & (track.t <= track.t[first])
    lowest = np.nanmin(speed[before]) if np.isfinite(speed[before]).any() else np.nan
    rise = scene.speed_at_step(i, first) - float(lowest)
    return max(rise, 0.0) if np.isfinite(rise) else 0.0


def _brake_event(scene: Scene, lead: int, follower: Neighbour, first: int, last: int,
                 limits: dict[str, float]) -> Event | None:
    """The braking phase as recorded: from the speed where it starts falling to where it
    stops; its intensity from the most speed lost within one second, by the speed the
    record gives (its positions' change, 0.5 s), not the detector's 1 s smoothing."""
    track, measured = scene.tracks[lead], scene.positions[lead]
    v0, v1 = scene.speed_at_step(lead, first), scene.speed_at_step(lead, last)
    # the record's intensity from the speed it gives (0.5 s), not the detector's 1 s one,
    # which flattens the hardest second; tracking noise counts for nothing
    best_ms2 = best_second_deceleration(track.t, measured.speed, first, last, ~measured.noise)
    if best_ms2 < limits["deceleration_ms2"] or v0 - v1 < limits["min_speed_drop_ms"]:
        return None  # the smoothing's brake, which the record's own speed does not show
    rise, half = _swell_before(scene, lead, first), limits["min_speed_drop_ms"] / 2
    if rise >= half and v0 - rise - v1 < half:
        return None  # a speed that went up and came back down within seconds: no brake
    start, end = float(track.t[first]), float(track.t[last])
    ego_speed, gap = scene.speed(follower.track, start), scene.gap(follower.track, lead, start)
    if ego_speed is None or gap is None:
        return None
    fields: dict[str, float | str] = {
        "ego_vel_kmh": ego_speed * KMH, "lead_vel_kmh": v0 * KMH, "duration_s": end - start,
        "delta_vel_kmh": (v1 - v0) * KMH, "npc_distance_m": gap,
        "brake_intensity": min(best_ms2 / limits["max_intensity_deceleration_ms2"], 1.0),
        "other_dir_traffic": "No", "lead_vehicle_type": vehicle(track),
    }
    code = "BR_BK" if ego_speed < limits["busy_below_ms"] else "BRAKE"
    return make_event(scene, code, follower.track, lead, start, end, fields)


# -- lane changes: cut-ins, cut-outs, the ego's own (CIN*, COUT*, LC*) ---------------------

@dataclass(frozen=True)
class LaneChange:
    track: int
    #: last step in the old lane, first step in the new one
    before: int
    after: int
    old_lane: float
    new_lane: float
    #: the event's window: the lane change, clipped to the track
    start_s: float
    end_s: float
    #: how long the lane change takes (a linear one as fast as recorded), s
    duration_s: float
    #: how far the car moved across the road (m)
    lateral_m: float
    #: when it crossed the line between the two lanes (recording time, s; NaN: no lateral
    #: positions, the lanes' change is all that is known)
    cross_s: float = float("nan")
    #: how far from its old lane's centre, toward the new lane, it was when the event starts
    #: (m; a track recorded mid-change starts well off it; NaN: unknown)
    start_offset_m: float = float("nan")

    @property
    def direction(self) -> str:
        """The way the changer moves; lane indexes grow to the right."""
        return "Left" if self.new_lane < self.old_lane else "Right"


def lane_changes(scene: Scene) -> Iterator[LaneChange]:
    """Changes of lane held for ``min_steady_s`` on both sides (a label flickering between
    two lanes while the car crosses their boundary is one change) that move the car at least
    ``min_lateral_m`` across the road; timed by that lateral motion."""
    limits = scene.thresholds["lane_change"]
    for i, track in enumerate(scene.tracks):
        lanes = np.array([scene.traffic.lane_of(track, k) for k in range(len(track.t))])
        found: list[LaneChange] = []
        candidates = [(b, a, float(lanes[b]), float(lanes[a]))
                      for b, a in _held_changes(track.t, lanes, limits["min_steady_s"])]
        candidates += _neighbour_flips(scene, i, lanes) if scene.town else []
        for before, after, old, new in candidates:
            if any(abs(track.t[after] - track.t[c.after]) < limits["min_steady_s"]
                   for c in found):
                continue  # the same crossing, seen by its lanes and by its lanelets
            change = _timed(scene, i, before, after, old, new, limits)
            if change is not None and crosses_line(scene, change, limits):
                found.append(change)
        yield from sorted(found, key=lambda c: c.start_s)


def _neighbour_flips(scene: Scene, i: int, lanes: Floats) -> list[tuple[int, int, float, float]]:
    """In town: each step where track ``i``'s lanelet changes into a same-direction
    neighbour's (the reader's lane index, held against lanelet seams and junction
    renumbering, may miss a real change), as ``(before, after, old lane, new lane)`` with
    the new lane's key one to the side the line says (indexes grow to the right)."""
    track = scene.tracks[i]
    names = np.asarray(track.lane).astype(str)
    flips = []
    for k in (np.flatnonzero(names[1:] != names[:-1]) + 1).tolist():
        line = border_between(scene.strips, names[k - 1], names[k])
        if line is not None:
            old = float(lanes[k - 1])
            flips.append((k - 1, k, old, old + line[1]))  # side +1: the new lane is right
    return flips


def crosses_line(scene: Scene, change: LaneChange, limits: dict[str, float]) -> bool:
    """A lane change is a crossing of the line (issue 32): the changer's centre is at least
    ``cross_margin_m`` on the old lane's side of the line between the two lanes before the
    change and on the new lane's side after it (within half ``max_duration_s`` of the
    crossing), ending there, by its own sideways motion, and it turns less than
    ``max_turn_deg`` over the change and over that window. The line is the border of the lane
    map's lanelets where the file gives one (two lanelets that are no neighbours, or one
    inside a junction, are a renumbering, no change); else midway between the lanes'
    centres from the lateral positions; with neither, the lanes' change is all there is."""
    track = scene.tracks[change.track]
    window = np.flatnonzero(np.abs(track.t - track.t[change.after])
                            <= limits["max_duration_s"] / 2)
    inside = (track.t >= change.start_s - 1e-6) & (track.t <= change.end_s + 1e-6)
    if max(turned_deg(track.heading[inside]), turned_deg(track.heading[window])) \
            > limits["max_turn_deg"]:
        return False
    if scene.strips:
        across = _past_border(scene, change, window)
    else:
        across = _past_middle(scene, change, window)
    if across is None:
        return not scene.strips  # no geometry to refuse it by; a map that has no line: no
    old_side = across[window <= change.before]
    new_side = across[window >= change.after]
    margin = limits["cross_margin_m"]
    if not (len(old_side) and len(new_side)) or float(np.min(old_side)) > -margin \
            or float(np.max(new_side)) < margin or float(new_side[-1]) <= 0:
        return False
    return _moved_itself(scene.lateral[change.track][window],
                         float(np.max(new_side) - np.min(old_side)), margin)


def _moved_itself(lateral: Floats, past_line_m: float, margin: float) -> bool:
    """The car went past the line by its own sideways motion, not by a line that moved
    under it (lanelets that widen or split): it moved across the road at least as far as
    it went from one side of the line to the other, within ``2 x margin`` (True where its
    lateral positions are unknown)."""
    known = lateral[np.isfinite(lateral)]
    return len(known) < 2 or past_line_m <= float(np.ptp(known)) + 2 * margin


def turned_deg(heading: Floats, ends: int = 3) -> float:
    """How far a heading series turns from its start to its end (deg; each end the mean of
    ``ends`` samples): a turn keeps its new heading, a lane change's own yaw swings back."""
    finite = np.unwrap(heading[np.isfinite(heading)])
    if len(finite) < 2:
        return 0.0
    n = min(ends, len(finite) // 2 or 1)
    return float(np.degrees(abs(np.mean(finite[-n:]) - np.mean(finite[:n]))))


def _past_border(scene: Scene, change: LaneChange, window: Steps) -> Floats | None:
    """How far past the line between its lanelets the changer's centre is at each step of
    ``window`` (m, + on the new lane's side); None where the lanelets share no line."""
    track = scene.tracks[change.track]
    old, new = str(track.lane[change.before]), str(track.lane[change.after])
    if {old, new} & set(scene.recording.junction_lanes):
        return None
    line = border_between(scene.strips, old, new)
    if line is None:
        return None
    border, side = line
    points = np.column_stack([track.x[window], track.y[window]])
    return -side * signed_distance(points, border)


def _past_middle(scene: Scene, change: LaneChange, window: Steps) -> Floats | None:
    """How far past the middle between its lanes' centres the changer is (m, + on the new
    lane's side), from its lateral position; None where the centres are unknown."""
    track, spacing = scene.tracks[change.track], scene.lane_spacing
    indexes = np.asarray(track.lane_index, dtype=float)
    if spacing is None or len(indexes) != len(track.t):
        return None
    old, new = float(indexes[change.before]), float(indexes[change.after])
    if not np.isfinite([old, new]).all() or old == new:
        return None
    toward = float(np.sign(spacing * (new - old)))
    across = (scene.lateral[change.track][window] - spacing * old) * toward
    if not np.isfinite(across).any():
        return None
    return np.where(np.isfinite(across), across, 0.0) - abs(spacing * (new - old)) / 2


def _held_changes(t: Floats, lanes: Floats, hold_s: float) -> list[tuple[int, int]]:
    """``(before, after)`` steps of each change between lanes held for ``hold_s`` (a track's
    first or last lane may be held for less where the track starts or ends): runs shorter
    than ``hold_s`` between two held lanes are the crossing itself, not lanes."""
    spans = runs_of_values(lanes)
    held = [(a, b) for a, b in spans
            if t[b] - t[a] >= hold_s - 1e-6 or a == 0 or b == len(t) - 1]
    changes = []
    for (_, last), (first, _) in zip(held, held[1:], strict=False):
        if lanes[last] != lanes[first]:
            middle = _crossing(lanes, last, first)
            changes.append((middle - 1, middle))
    return changes


def runs_of_values(values: Floats) -> list[tuple[int, int]]:
    """``(first, last)`` of each run of equal values."""
    if not len(values):
        return []
    cuts = np.flatnonzero(values[1:] != values[:-1]) + 1
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts - 1, [len(values) - 1]])
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def _crossing(lanes: Floats, last_old: int, first_new: int) -> int:
    """The first step of the last stretch of the new lane before ``first_new`` (the
    flicker's end): the car is over the line then."""
    k = first_new
    while k - 1 > last_old and lanes[k - 1] == lanes[first_new]:
        k -= 1
    return k


def _timed(scene: Scene, i: int, before: int, after: int, old: float, new: float,
           limits: dict[str, float]) -> LaneChange | None:
    """The lane change's timing from the car's lateral motion: the time it takes from
    ``edge_share`` of its way across to ``edge_share`` left, as the linear lane change a
    scenario plays that is as fast there (that span / (1 - 2 x edge_share)); None when it
    moves less than ``min_lateral_m`` sideways. The event's window is clipped to the track;
    its duration is the lane change's."""
    track, lateral = scene.tracks[i], scene.lateral[i]
    if not np.isfinite(lateral[[before, after]]).all():  # lanes only: a change of set length
        half = limits["duration_s"] / 2
        crossing = float(track.t[after])
        # the lane label changes where the car's centre crosses into the next lane (a
        # lanelet's border is the line): the crossing, from an unknown offset (its centre)
        start = max(float(track.t[0]), crossing - half)
        return LaneChange(i, before, after, old, new, start,
                          min(float(track.t[-1]), crossing + half), limits["duration_s"],
                          float("nan"), crossing, 0.0)
    near = np.abs(track.t - track.t[after]) <= limits["max_duration_s"]
    window = np.flatnonzero(near & np.isfinite(lateral))
    y0, y1 = float(lateral[window[0]]), float(lateral[window[-1]])
    moved = y1 - y0
    if abs(moved) < limits["min_lateral_m"] or np.sign(moved) != (1 if new < old else -1):
        return None
    share = limits["edge_share"]
    done = (lateral[window] - y0) / moved
    split = int(np.searchsorted(window, after))
    started = window[:split][done[:split] <= share]
    ended = window[split:][done[split:] >= 1 - share]
    first = _when(track.t, done, window, started[-1], share) if len(started) \
        else float(track.t[window[0]])
    last = _when(track.t, done, window, ended[0] - 1, 1 - share) if len(ended) \
        else float(track.t[window[-1]])
    duration = (last - first) / (1 - 2 * share)
    start = max(first - share * duration, float(track.t[0]))
    cross, offset = _line_crossing(scene, i, before, after, start)
    if not np.isfinite(cross):  # no lane indexes (urban maps): halfway across is the line
        halfway = window[:-1][(done[:-1] < 0.5) & (done[1:] >= 0.5)]
        nearest = halfway[np.argmin(np.abs(halfway - after))] if len(halfway) else after - 1
        cross, offset = _when(track.t, done, window, int(nearest), 0.5), 0.0
    return LaneChange(i, before, after, old, new, start,
                      min(first - share * duration + duration, float(track.t[-1])), duration,
                      abs(moved), cross, offset)


def _line_crossing(scene: Scene, i: int, before: int, after: int,
                   start: float) -> tuple[float, float]:
    """When track ``i`` crossed the line between its lanes at steps ``before`` and ``after``
    (its lateral position passing the middle of their centres, interpolated between steps,
    the passing nearest ``after``), and how far it was from the old lane's centre toward the
    new one at ``start``; NaNs where the lanes' centres are unknown (no lane indexes)."""
    track, lateral, spacing = scene.tracks[i], scene.lateral[i], scene.lane_spacing
    indexes = np.asarray(track.lane_index, dtype=float)
    if spacing is None or len(indexes) != len(track.t):
        return float("nan"), float("nan")
    old, new = float(indexes[before]), float(indexes[after])
    if not np.isfinite([old, new]).all() or old == new:
        return float("nan"), float("nan")
    toward = float(np.sign(spacing * (new - old)))
    across = (lateral - spacing * old) * toward  # m from the old centre toward the new one
    line = abs(spacing * (new - old)) / 2
    past = np.where(np.isfinite(across), across >= line, False)
    flips = np.flatnonzero(past[1:] & ~past[:-1])  # step k -> k + 1 goes over the line
    if not len(flips):
        return float("nan"), float("nan")
    k = int(flips[np.argmin(np.abs(flips + 1 - after))])
    share = (line - across[k]) / (across[k + 1] - across[k])
    cross = float(track.t[k] + share * (track.t[k + 1] - track.t[k]))
    at = int(np.argmin(np.abs(track.t - start)))
    return cross, float(across[at])


def _when(t: Floats, done: Floats, window: Steps, step: int,
          share: float) -> float:
    """When the share of the way done passes ``share`` between ``step`` and the next step
    (linear in between)."""
    k = int(np.searchsorted(window, step))
    if k + 1 >= len(window):
        return float(t[step])
    a, b = float(done[k]), float(done[k + 1])
    part = 0.0 if b == a else min(max((share - a) / (b - a), 0.0), 1.0)
    return float(t[window[k]] + part * (t[window[k + 1]] - t[window[k]]))


def cuts(scene: Scene) -> Iterator[Event]:
    """A changer seen from the car it cuts in front of / behind (CINF / CINB) or leaves from
    in front of / behind (COUTF / COUTB)."""
    limit = scene.thresholds["cut"]["max_gap_m"]
    least = scene.thresholds["cut"]["min_ego_speed_ms"]
    for change in lane_changes(scene):
        old, new = _lane_steps(scene, change)
        for code, neighbour in (("CINF", scene.follower(change.track, new)),
                                ("CINB", scene.lead(change.track, new)),
                                ("COUTF", scene.follower(change.track, old)),
                                ("COUTB", scene.lead(change.track, old))):
            if neighbour is None or neighbour.gap_m > limit \
                    or not moves(scene, neighbour.track, change.start_s, change.end_s, least):
                continue
            event = _cut_event(scene, code, change, neighbour.track)
            if event is not None:
                yield event


def _lane_steps(scene: Scene, change: LaneChange) -> tuple[int, int]:
    """The changer's steps at which its old and its new lane's cars are looked at: on a
    highway its last step in the old lane and first in the new; in town, where that is
    read from paths and the changer is on the line then, the event's start and end."""
    if not scene.town:
        return change.before, change.after
    first, last = scene.step_at(change.track, change.start_s), \
        scene.step_at(change.track, change.end_s)
    return (change.before if first is None else first), (change.after if last is None else last)


def _cut_event(scene: Scene, code: str, change: LaneChange, ego: int) -> Event | None:
    npc = change.track
    ego_start, npc_start = scene.speed(ego, change.start_s), scene.speed(npc, change.start_s)
    npc_end, gap = scene.speed(npc, change.end_s), scene.gap(ego, npc, change.start_s)
    if ego_start is None or npc_start is None or npc_end is None or gap is None:
        return None
    fields: dict[str, float | str] = {
        "ego_vel_kmh": ego_start * KMH, "cutter_vel_kmh": (npc_start - ego_start) * KMH,
        "delta_vel_kmh": (npc_end - npc_start) * KMH,
        "duration_s": change.duration_s, "npc_distance_m": gap,
        "other_dir_traffic": "No", "direction": change.direction,
        "lead_vehicle_type": vehicle(scene.tracks[npc]),
    }
    fields.update(lateral_fields(scene, change))
    return make_event(scene, code, ego, npc, change.start_s, change.end_s, fields)


#: lanes' spacing where the lateral positions do not tell it (urban maps): with the changer
#: taken to start on its lane's centre, the scenario's timing does not depend on it (m)
NOMINAL_LANE_M = 3.5
#: the lane change as measured from the lateral position, in a mined record's params (not in
#: MOOVE's layouts: a MOOVE row keeps its duration and is played as one linear change)
LATERAL_FIELDS = ("lane_change_cross_s", "lane_change_offset_m", "lane_change_width_m")


def lateral_fields(scene: Scene, change: LaneChange) -> dict[str, float | str]:
    """When the changer crossed the line (s from the event's start), how far off its old
    lane's centre toward the new one it was then (m) and how far apart the two lanes'
    centres are (m); none where the lateral positions do not tell."""
    spacing, indexes = scene.lane_spacing, scene.tracks[change.track].lane_index
    across = abs(spacing * (indexes[change.after] - indexes[change.before])) \
        if spacing and len(indexes) > change.after else NOMINAL_LANE_M
    values = (change.cross_s - change.start_s, change.start_offset_m, across)
    if not np.isfinite(values).all():
        return {}
    return {key: float(value) for key, value in zip(LATERAL_FIELDS, values, strict=True)}


def own_lane_changes(scene: Scene) -> Iterator[Event]:
    """The ego changes lane: LCF when the nearest car of its new lane is ahead (or none is
    near), LCB when it is behind."""
    limit = scene.thresholds["ego_lane_change"]["max_gap_m"]
    for change in lane_changes(scene):
        i = change.track
        nearest, ahead = scene.traffic.nearest_in_lane(i, change.after, change.new_lane)
        behind = nearest is not None and nearest.gap_m <= limit and not ahead
        start, end = scene.speed(i, change.start_s), scene.speed(i, change.end_s)
        if start is None or end is None:
            continue
        fields: dict[str, float | str] = {
            "ego_vel_begin_kmh": start * KMH, "ego_vel_end_kmh": end * KMH,
            "duration_s": change.duration_s, "other_dir_traffic": "No",
            "direction": change.direction}
        fields.update(lateral_fields(scene, change))
        yield make_event(scene, "LCB" if behind else "LCF", i, None, change.start_s,
                         change.end_s, fields)


# -- car following (FLF, FLB) -----------------------------------------------------------------

def following(scene: Scene) -> Iterator[Event]:
    """FLF/FLB episodes: the same lead (follower) directly ahead of (behind) the ego, both
    moving, by the speed the record gives (its positions', :meth:`Scene.speed_at_step`), so
    an episode is never dropped for an end its record would start below the limit."""
    limits = scene.thresholds["follow"]
    least = limits["min_speed_ms"]
    for i, track in enumerate(scene.tracks):
        for code, find in (("FLF", scene.lead), ("FLB", scene.follower)):
            partner = [find(i, k) for k in range(len(track.t))]
            ids = np.array([-1 if p is None or p.gap_m > limits["max_gap_m"]
                            or scene.speed_at_step(p.track, p.step) < least else p.track
                            for p in partner])
            ids[scene.positions[i].filled < least] = -1
            clear, noisy = _apart(scene, i, partner, limits["min_gap_m"])
            ids[~clear & ~noisy] = -1
            yield from _episodes(scene, code, i, ids, clear, limits)


def _apart(scene: Scene, ego: int, partner: list[Neighbour | None],
           least_m: float) -> tuple[Mask, Mask]:
    """Per step of the ego: whether its partner's bumper is more than ``least_m`` away,
    along the path and along the road (the record's series gap; its sign is the road
    frame's, which a town's bends can turn), and whether either car's position is tracking
    noise then. Two boxes side by side or overlapping (Lankershim 2-10's 2713 and 2731,
    4.0-4.8 s) follow nobody."""
    track = scene.tracks[ego]
    clear, noisy = np.zeros(len(track.t), bool), np.zeros(len(track.t), bool)
    for k, found in enumerate(partner):
        if found is None:
            continue
        noisy[k] = scene.positions[ego].noise[k] or scene.positions[found.track].noise[found.step]
        road = scene.gap(ego, found.track, float(track.t[k]))
        clear[k] = found.gap_m > least_m and road is not None and abs(road) > least_m
    return clear, noisy


def _episodes(scene: Scene, code: str, ego: int, ids: Steps, clear: Mask,
              limits: dict[str, float]) -> Iterator[Event]:
    """Each run of one partner, from its first step that is ``clear`` with the follower in
    the lead's lane to its last that is ``clear`` (a run may pass tracking noise, never
    start or end in it)."""
    track = scene.tracks[ego]
    for other in set(ids[ids >= 0].tolist()):
        for first, last in runs(ids == other):
            kept = (np.flatnonzero(clear[first:last + 1]) + first).tolist()
            start = next((k for k in kept if _in_lead_lane(scene, code, ego, int(other), k)),
                         None)
            if start is None:
                continue
            yield from _windows(scene, code, ego, int(other), float(track.t[start]),
                                float(track.t[kept[-1]]), limits)


def _in_lead_lane(scene: Scene, code: str, ego: int, npc: int, k: int) -> bool:
    """Whether at the ego's step ``k`` the follower drives where the lead drove: a car
    cutting in has the lead on its path while still beside it (Peachtree 2's 500 behind
    512, 0.6-3.2 s), which no follow can start from."""
    step = scene.step_at(npc, float(scene.tracks[ego].t[k]))
    if step is None:
        return False
    lead, follower = ((npc, step), (ego, k)) if code == "FLF" else ((ego, k), (npc, step))
    return scene.behind_in_lane(*lead, *follower)


def _windows(scene: Scene, code: str, ego: int, npc: int, start: float, end: float,
             limits: dict[str, float]) -> Iterator[Event]:
    """A following episode as one record, or, past ``max_duration_s``, as consecutive
    records of equal length (each at least ``min_duration_s``): the recorded series carries
    the speeds between the ends, so no window need be a linear change."""
    length = end - start
    if length < limits["min_duration_s"] - 1e-6:
        return
    pieces = max(1, int(np.ceil(length / limits["max_duration_s"] - 1e-9)))
    while pieces > 1 and length / pieces < limits["min_duration_s"]:
        pieces -= 1
    bounds = np.linspace(start, end, pieces + 1)
    for first, last in zip(bounds[:-1], bounds[1:], strict=True):
        event = follow_event(scene, code, ego, npc, float(first), float(last), limits)
        if event is not None:
            yield event


def follow_event(scene: Scene, code: str, ego: int, npc: int, start: float, end: float,
                 limits: dict[str, float]) -> Event | None:
    """FLF/FLB over ``start``..``end``: speeds and gaps at both ends (None if either car is
    missing or too slow then)."""
    speeds = [v for i in (ego, npc) for t in (start, end) if (v := scene.speed(i, t)) is not None]
    gaps = [g for t in (start, end) if (g := scene.gap(ego, npc, t)) is not None]
    if len(speeds) < 4 or len(gaps) < 2 or min(speeds) < limits["min_speed_ms"]:
        return None
    ego0, ego1, npc0, npc1 = speeds
    gap0, gap1 = abs(gaps[0]), abs(gaps[1])
    fields: dict[str, float | str] = {
        "ego_vel_begin_kmh": ego0 * KMH, "ego_vel_end_kmh": ego1 * KMH,
        "lead_vel_begin_kmh": npc0 * KMH, "lead_vel_end_kmh": npc1 * KMH,
        "npc_distance_begin_m": gap0, "npc_distance_end_m": gap1,
        "lead_dist_traveled_m": _travelled(scene.tracks[npc], start, end),
        "duration_s": end - start, "other_dir_traffic": "No",
        "behavior_type": _behaviour(gap0, gap1),
        "lead_vehicle_type": vehicle(scene.tracks[npc]),
    }
    return make_event(scene, code, ego, npc, start, end, fields)


def _behaviour(gap0: float, gap1: float) -> str:
    """MOOVE's following behaviours as ScenWeave reads them: B4 a long gap, B1 the gap
    opens, B2 it closes, B3 it holds (within 2 m)."""
    if gap0 > 49.0:
        return "B4"
    if gap1 - gap0 > 2.0:
        return "B1"
    if gap0 - gap1 > 2.0:
        return "B2"
    return "B3"


def _travelled(track: Track, start: float, end: float) -> float:
    inside = (track.t >= start - 1e-6) & (track.t <= end + 1e-6)
    s = track.s[inside]
    return float(s[-1] - s[0]) if len(s) else 0.0


# -- free rides (FRF, FRB) -------------------------------------------------------------------

#: the surrounding vehicles' slots of a free ride and the lane each is in, from the ego's
#: lane (lane indexes grow to the right)
SLOT_LANES = (("center", 0), ("right", 1), ("left", -1))
ABSENT_POSITION, ABSENT_SPEED = -1.0, -3.6


def free_rides(scene: Scene) -> Iterator[Event]:
    """The ego drives on in its lane, changing none, with nobody to follow (no car ahead
    within ``free_gap_m``, as far as the recording sees), at least ``min_duration_s``: FRF with
    the nearest car ahead in its lane and each lane beside it (within ``slot_range_m``),
    FRB with those behind; one record per stretch, or per piece of at most
    ``max_duration_s``; none where no car surrounds it."""
    limits = scene.thresholds["free_ride"]
    seen_to = max((float(track.s.max()) for track in scene.tracks if len(track.s)), default=0.0)
    changing = [(c.track, c.start_s, c.end_s) for c in lane_changes(scene)]
    for i, track in enumerate(scene.tracks):
        lanes = np.array([scene.traffic.lane_of(track, k) for k in range(len(track.t))])
        free = np.array([_free(scene, i, k, limits, seen_to) for k in range(len(track.t))])
        for _, start, end in (c for c in changing if c[0] == i):  # its own lane change
            free &= (track.t < start - 1e-6) | (track.t > end + 1e-6)
        for first, last in runs(free):
            # in town a lane's key changes at lanelet seams and junctions without the car
            # changing lane: its own lane changes (crossings of the line) are left out above
            pieces = [(0, last - first)] if scene.town else runs_of_values(lanes[first:last + 1])
            for a, b in pieces:
                yield from _free_pieces(scene, i, first + a, first + b, limits)


def _free(scene: Scene, i: int, k: int, limits: dict[str, float], seen_to: float) -> bool:
    track = scene.tracks[i]
    sees = scene.sees_ahead(i, k, limits["free_gap_m"]) if scene.town \
        else track.s[k] + limits["free_gap_m"] <= seen_to
    if scene.motion[i].speed[k] < limits["min_speed_ms"] or not sees:
        return False  # too slow, or the road it would see ahead is not recorded
    lead = scene.lead(i, k)
    if lead is not None:
        return lead.gap_m > limits["free_gap_m"]
    return not _removed_ahead(scene, i, k, limits["free_gap_m"])


def _removed_ahead(scene: Scene, i: int, k: int, within_m: float) -> bool:
    """A vehicle the file took out drives ahead of track ``i`` in its lane, within
    ``within_m`` of its centre (the lead the file leaves out)."""
    track = scene.tracks[i]
    lane = scene.traffic.lane_of(track, k)
    for other in scene.recording.removed:
        step = np.flatnonzero(np.abs(other.t - track.t[k]) < 1e-6)
        if len(step) and scene.traffic.lane_of(other, int(step[0])) == lane \
                and 0 < other.s[step[0]] - track.s[k] <= within_m + track.length_m:
            return True
    return False


def _free_pieces(scene: Scene, i: int, first: int, last: int,
                 limits: dict[str, float]) -> Iterator[Event]:
    track = scene.tracks[i]
    start, end = float(track.t[first]), float(track.t[last])
    length = end - start
    if length < limits["min_duration_s"] - 1e-6:
        return
    pieces = max(1, int(np.ceil(length / limits["max_duration_s"] - 1e-9)))
    bounds = np.linspace(start, end, pieces + 1)
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        for code, ahead in (("FRF", True), ("FRB", False)):
            event = free_ride_event(scene, code, i, float(a), float(b), ahead, limits)
            if event is not None:
                yield event


def free_ride_event(scene: Scene, code: str, ego: int, start: float, end: float, ahead: bool,
               limits: dict[str, float]) -> Event | None:
    track = scene.tracks[ego]
    k0, k1 = scene.step_at(ego, start), scene.step_at(ego, end)
    if k0 is None or k1 is None:
        return None
    lane = scene.traffic.lane_of(track, k0)
    slots = {name: _nearest(scene, ego, start, lane + shift, ahead, limits["slot_range_m"])
             for name, shift in SLOT_LANES}
    if scene.town:  # lanes bend and are renumbered: the slots from the positions
        slots = _town_slots(scene, ego, k0, ahead, limits["slot_range_m"])
    if all(j is None for j in slots.values()):
        return None
    v0, v1 = scene.speed_at_step(ego, k0), scene.speed_at_step(ego, k1)
    fields: dict[str, float | str] = {
        "ego_vel_begin_kmh": v0 * KMH, "ego_vel_end_kmh": v1 * KMH,
        "ego_dist_traveled_m": float(track.s[k1] - track.s[k0]),
        "ego_acc_mean_ms2": (v1 - v0) / (end - start), "duration_s": end - start,
        "ego_lane_index": float(track.lane_index[k0]) if len(track.lane_index) else lane,
        "lane_count": float(_lane_count(scene)),
        "ego_lat_offset_m": 0.0, "speed_limit_kmh": 0.0,
    }
    fields |= ({"driving_side": "Right"} if ahead else {"other_dir_traffic": "No"})
    for name, j in slots.items():
        fields |= _slot_fields(scene, name, ego, j, start, end)
    roles = {"ego": ego} | {name: j for name, j in slots.items() if j is not None}
    return Event(code, track.id, None if slots["center"] is None
                 else scene.tracks[slots["center"]].id, round(start, 3), round(end, 3),
                 {k: round(v, 2) if isinstance(v, float) else v for k, v in fields.items()},
                 scene.series(roles, ego, start, end))


#: in town, a car beside the ego is this far across from its centre line (m) ...
BESIDE_M = (1.75, 5.5)
#: ... heading its way within this (rad)
BESIDE_HEADING_RAD = 0.8


def _town_slots(scene: Scene, ego: int, k: int, ahead: bool,
                within_m: float) -> dict[str, int | None]:
    """A town free ride's surrounding cars at the ego's step ``k``: the centre is the car
    on its path ahead (FRF) or the one behind whose path it is on (FRB); left and right the
    nearest car ahead (behind) a lane's width to that side, heading its way, within
    ``within_m`` (bumper gap)."""
    centre = scene.lead(ego, k) if ahead else scene.follower(ego, k)
    slots: dict[str, int | None] = {
        "center": centre.track if centre is not None and centre.gap_m <= within_m else None}
    me, t = scene.tracks[ego], float(scene.tracks[ego].t[k])
    h = np.array([np.cos(me.heading[k]), np.sin(me.heading[k])])
    best: dict[str, tuple[float, int]] = {}
    for j, other in enumerate(scene.tracks):
        m = scene.step_at(j, t) if j != ego else None
        if m is None or abs(np.angle(np.exp(1j * (other.heading[m] - me.heading[k])))) \
                > BESIDE_HEADING_RAD:
            continue
        rel = np.array([other.x[m] - me.x[k], other.y[m] - me.y[k]])
        along, across = float(rel @ h), float(h[0] * rel[1] - h[1] * rel[0])
        gap = abs(along) - (me.length_m + other.length_m) / 2
        side = "left" if across > 0 else "right"
        if BESIDE_M[0] < abs(across) <= BESIDE_M[1] and (along > 0) == ahead \
                and gap <= within_m and (side not in best or gap < best[side][0]):
            best[side] = (gap, j)
    return slots | {side: best[side][1] if side in best else None for side in ("left", "right")}


def _nearest(scene: Scene, ego: int, t: float, lane: float, ahead: bool,
             within_m: float) -> int | None:
    """The nearest car of ``lane`` ahead of (or behind) the ego at ``t`` within
    ``within_m`` (bumper gap)."""
    best, best_gap = None, within_m
    for j, other in enumerate(scene.tracks):
        k = scene.step_at(j, t)
        if j == ego or k is None or scene.traffic.lane_of(other, k) != lane:
            continue
        gap = scene.gap(ego, j, t)
        if gap is not None and (gap > 0 if ahead else gap < 0) and abs(gap) <= best_gap:
            best, best_gap = j, abs(gap)
    return best


def _slot_fields(scene: Scene, name: str, ego: int, j: int | None, start: float,
                 end: float) -> dict[str, float | str]:
    """A slot's bumper gaps (unsigned, as MOOVE gives them) and speeds at both ends; the
    layout's 'absent' values where no car is there (or, at the end, where it has left)."""
    values: dict[str, float | str] = {
        f"{name}_posx_begin_m": ABSENT_POSITION, f"{name}_posx_end_m": ABSENT_POSITION,
        f"{name}_vel_begin_ms": ABSENT_SPEED, f"{name}_vel_end_ms": ABSENT_SPEED,
        f"{name}_vehicle_type": "None"}
    if j is None:
        return values
    values[f"{name}_vehicle_type"] = vehicle(scene.tracks[j])
    for when, t in (("begin", start), ("end", end)):
        gap, speed = scene.gap(ego, j, t), scene.speed(j, t)
        if gap is not None and speed is not None:
            values[f"{name}_posx_{when}_m"] = abs(gap)
            values[f"{name}_vel_{when}_ms"] = speed
    return values


def _lane_count(scene: Scene) -> int:
    lanes = {float(x) for track in scene.tracks for x in np.asarray(track.lane_index, float)
             if np.isfinite(x)}
    return len(lanes)

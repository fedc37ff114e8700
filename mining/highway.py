"""The highway classes in a recording of a whole road: braking leads (BRAKE, BR_BK), cut-ins
and cut-outs (CIN*, COUT*), the ego's own lane changes (LCF, LCB) and car following (FLF, FLB).

Each detector looks at every track as a possible ego (the recording car of a MOOVE record) and
returns events with the fields a MOOVE file of that class gives (its layout's column names and
units: km/h, bumper gaps). Thresholds come from ``mining/thresholds.json``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from scenweave.mining.motion import runs
from scenweave.mining.scene import KMH, Event, Scene, make_event, vehicle
from scenweave.mining.tracks import Track
from scenweave.mining.traffic import Neighbour

# -- braking leads (BRAKE, BR_BK) ----------------------------------------------------------

def braking_leads(scene: Scene) -> Iterator[Event]:
    limits = scene.thresholds["brake"]
    for i, track in enumerate(scene.tracks):
        motion = scene.motion[i]
        for hard_first, hard_last in runs(motion.acceleration < -limits["deceleration_ms2"]):
            first, last = _widened(motion.acceleration > -limits["onset_ms2"], hard_first,
                                   hard_last)
            took = float(track.t[last] - track.t[first])
            drop = float(motion.speed[first] - motion.speed[last])
            if took < limits["min_duration_s"] or drop < limits["min_speed_drop_ms"] \
                    or motion.speed[first] < limits["min_start_speed_ms"]:
                continue
            follower = scene.traffic.follower(i, first)
            if follower is None or follower.gap_m > limits["follower_within_m"]:
                continue
            yield _brake_event(scene, i, follower, first, last, limits)


def _widened(calm: np.ndarray, first: int, last: int) -> tuple[int, int]:
    """The run ``first..last`` grown to the neighbouring calm steps (exclusive)."""
    while first > 0 and not calm[first - 1]:
        first -= 1
    while last + 1 < len(calm) and not calm[last + 1]:
        last += 1
    return first, last


def _brake_event(scene: Scene, lead: int, follower: Neighbour, first: int, last: int,
                 limits: dict[str, float]) -> Event | None:
    """The braking as the linear speed change a scenario plays: from the speed before it to
    the speed after it at the peak deceleration, centred where the speed is half way down
    (smoothing blurs the episode's edges, not its middle)."""
    track, motion = scene.tracks[lead], scene.motion[lead]
    v0, v1 = float(motion.speed[first]), float(motion.speed[last])
    peak = float(-motion.acceleration[first:last + 1].min())
    duration = (v0 - v1) / peak
    if duration < max(limits["min_duration_s"], scene.thresholds["smoothing"]["window_s"]):
        return None  # shorter than the smoothing window: its peak is not measured, only blurred
    middle = first + int(np.argmax(motion.speed[first:last + 1] <= (v0 + v1) / 2))
    start = max(float(track.t[middle]) - duration / 2, float(track.t[0]))
    ego_speed, gap = scene.speed(follower.track, start), scene.gap(follower.track, lead, start)
    if ego_speed is None or gap is None:
        return None
    fields = {
        "ego_vel_kmh": ego_speed * KMH, "lead_vel_kmh": v0 * KMH, "duration_s": duration,
        "delta_vel_kmh": (v1 - v0) * KMH, "npc_distance_m": gap,
        "brake_intensity": min(peak / limits["max_intensity_deceleration_ms2"], 1.0),
        "other_dir_traffic": "No", "lead_vehicle_type": vehicle(track),
    }
    code = "BR_BK" if ego_speed < limits["busy_below_ms"] else "BRAKE"
    return make_event(scene, code, follower.track, lead, start, start + duration, fields)


# -- lane changes: cut-ins, cut-outs, the ego's own (CIN*, COUT*, LC*) ---------------------

@dataclass(frozen=True)
class LaneChange:
    track: int
    #: last step in the old lane, first step in the new one
    before: int
    after: int
    old_lane: float
    new_lane: float
    start_s: float
    end_s: float

    @property
    def direction(self) -> str:
        """Lane indexes grow to the right, in the direction of travel."""
        return "Left" if self.new_lane < self.old_lane else "Right"


def lane_changes(scene: Scene) -> Iterator[LaneChange]:
    limits = scene.thresholds["lane_change"]
    for i, track in enumerate(scene.tracks):
        lanes = np.array([scene.traffic.lane_of(track, k) for k in range(len(track.t))])
        for before in np.flatnonzero(lanes[1:] != lanes[:-1]).tolist():
            after = before + 1
            crossing = float(track.t[after])
            if not (_steady(track.t, lanes, before, -1, limits["min_steady_s"])
                    and _steady(track.t, lanes, after, +1, limits["min_steady_s"])):
                continue
            half = limits["duration_s"] / 2
            start = max(float(track.t[0]), crossing - half)
            end = min(float(track.t[-1]), crossing + half)
            yield LaneChange(i, before, after, float(lanes[before]), float(lanes[after]),
                             start, end)


def _steady(t: np.ndarray, lanes: np.ndarray, k: int, way: int, hold_s: float) -> bool:
    """The lane at step ``k`` is held for ``hold_s`` before (way -1) or after (+1) it."""
    j = k
    while 0 <= j + way < len(lanes) and lanes[j + way] == lanes[k]:
        j += way
    return abs(float(t[j] - t[k])) >= hold_s - 1e-6


def cuts(scene: Scene) -> Iterator[Event]:
    """A changer seen from the car it cuts in front of / behind (CINF / CINB) or leaves from
    in front of / behind (COUTF / COUTB)."""
    limit = scene.thresholds["cut"]["max_gap_m"]
    for change in lane_changes(scene):
        traffic = scene.traffic
        for code, neighbour in (("CINF", traffic.follower(change.track, change.after)),
                                ("CINB", traffic.leader(change.track, change.after)),
                                ("COUTF", traffic.follower(change.track, change.before)),
                                ("COUTB", traffic.leader(change.track, change.before))):
            if neighbour is not None and neighbour.gap_m <= limit:
                yield _cut_event(scene, code, change, neighbour.track)


def _cut_event(scene: Scene, code: str, change: LaneChange, ego: int) -> Event | None:
    npc = change.track
    ego_start, npc_start = scene.speed(ego, change.start_s), scene.speed(npc, change.start_s)
    npc_end, gap = scene.speed(npc, change.end_s), scene.gap(ego, npc, change.start_s)
    if None in (ego_start, npc_start, npc_end, gap):
        return None
    fields = {
        "ego_vel_kmh": ego_start * KMH, "cutter_vel_kmh": (npc_start - ego_start) * KMH,
        "delta_vel_kmh": (npc_end - npc_start) * KMH,
        "duration_s": change.end_s - change.start_s, "npc_distance_m": gap,
        "other_dir_traffic": "No", "direction": change.direction,
        "lead_vehicle_type": vehicle(scene.tracks[npc]),
    }
    return make_event(scene, code, ego, npc, change.start_s, change.end_s, fields)


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
        fields = {"ego_vel_begin_kmh": start * KMH, "ego_vel_end_kmh": end * KMH,
                  "duration_s": change.end_s - change.start_s, "other_dir_traffic": "No",
                  "direction": change.direction}
        yield make_event(scene, "LCB" if behind else "LCF", i, None, change.start_s,
                         change.end_s, fields)


# -- car following (FLF, FLB) -----------------------------------------------------------------

def following(scene: Scene) -> Iterator[Event]:
    limits = scene.thresholds["follow"]
    for i, track in enumerate(scene.tracks):
        for code, find in (("FLF", scene.traffic.leader), ("FLB", scene.traffic.follower)):
            partner = [find(i, k) for k in range(len(track.t))]
            ids = np.array([-1 if p is None or p.gap_m > limits["max_gap_m"] else p.track
                            for p in partner])
            slow = scene.motion[i].speed < limits["min_speed_ms"]
            ids[slow] = -1
            yield from _episodes(scene, code, i, ids, limits)


def _episodes(scene: Scene, code: str, ego: int, ids: np.ndarray,
              limits: dict[str, float]) -> Iterator[Event]:
    track = scene.tracks[ego]
    for other in set(ids[ids >= 0].tolist()):
        for first, last in runs(ids == other):
            yield from _windows(scene, code, ego, int(other), float(track.t[first]),
                                float(track.t[last]), limits)


def _windows(scene: Scene, code: str, ego: int, npc: int, start: float, end: float,
             limits: dict[str, float]) -> Iterator[Event]:
    """A following episode cut into the longest windows (``min_duration_s`` to
    ``max_duration_s``) that a linear speed change of both cars describes: a MOOVE following
    record gives start and end speeds and gaps only, so the end gap must follow from them."""
    shortest, step = limits["min_duration_s"], limits["window_step_s"]
    while end - start >= shortest - 1e-6:
        stop = min(end, start + limits["max_duration_s"])
        while stop - start >= shortest - 1e-6 and not _linear(scene, ego, npc, start, stop,
                                                               limits["linear_within_m"]):
            stop -= step
        if stop - start < shortest - 1e-6:
            start += step
            continue
        event = follow_event(scene, code, ego, npc, start, stop, limits)
        if event is not None:
            yield event
        start = stop


def _linear(scene: Scene, ego: int, npc: int, start: float, stop: float,
            within_m: float) -> bool:
    values = [scene.speed(i, t) for i in (ego, npc) for t in (start, stop)]
    gaps = [scene.gap(ego, npc, t) for t in (start, stop)]
    if None in values or None in gaps:
        return False
    ego0, ego1, npc0, npc1 = values
    made = gaps[0] + ((npc0 + npc1) - (ego0 + ego1)) / 2 * (stop - start)
    return abs(made - gaps[1]) <= within_m


def follow_event(scene: Scene, code: str, ego: int, npc: int, start: float, end: float,
                 limits: dict[str, float]) -> Event | None:
    """FLF/FLB over ``start``..``end``: speeds and gaps at both ends (None if either car is
    missing or too slow then)."""
    speeds = [scene.speed(i, t) for i in (ego, npc) for t in (start, end)]
    gaps = [scene.gap(ego, npc, t) for t in (start, end)]
    if None in speeds or None in gaps or min(speeds) < limits["min_speed_ms"]:
        return None
    ego0, ego1, npc0, npc1 = speeds
    gap0, gap1 = abs(gaps[0]), abs(gaps[1])
    fields = {
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

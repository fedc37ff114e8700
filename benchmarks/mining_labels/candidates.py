"""Candidates for hand labels of a town snippet, each with the raw evidence to decide it by.

Reads one CommonRoad file as the reader gives it (positions, headings, lanelets, lights) and
its lane map (the lanelets' borders and neighbours), and lists, from the positions alone and
independently of ``mining/``'s detectors:

- every change of lanelet into a same-direction neighbour, with how far the car's centre was
  from the line between the two lanes before and after it (the border), its heading change
  and whether a lanelet is inside a junction;
- every car ahead in another's path (within 1.6 m of the path the follower later drives,
  heading the same way), as runs of following, braking of that lead, and stretches with no
  car ahead within 50 m;
- every stop-line crossing and every stop at a stop line with the colour of the light for
  the car's lane and movement;
- stretches on lanes between junctions (no light approach), faster than 2 m/s.

The labels of ``benchmarks/mining_labels/`` were decided from this list, candidate by
candidate, by these rules (the evidence and the reason in each label's ``notes``):

- lane change: the centre goes at least ``CROSS_MARGIN_M`` past the line on both sides
  within 3 s of the label change, it moves 1.5 m or more across its lane over those 6 s
  (and keeps it: a weave there and back is none), the heading turns less than 20 deg, no
  junction lanelet;
- free ride: moving faster than 2 m/s, no car in the path ahead within 50 m (junction lanes
  included), the point 50 m ahead on its path recorded (a car was within 3 m of it), at
  least 4 s, no lane change of its own; FRF/FRB need a car ahead/behind within 80 m in its
  lane or the ones beside it; the NPC is the nearest car on its path ahead (FRF) or the one
  behind whose path it is on (FRB), within 80 m;
- following: the same car in the path ahead within 50 m, both faster than 2 m/s, 4 s;
- braking: a lead in the path within 50 m loses 2 m/s (from 3 m/s or more) and 2 m/s in its
  hardest second, its speed from its positions with tracking noise left out; the follower
  moves; BR_BK when the follower is slower than 13.9 m/s.

    .venv/bin/python benchmarks/mining_labels/candidates.py FILE.xml > candidates.json
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from scenweave.mining.readers import read_recordings  # noqa: E402
from scenweave.mining.readers.lanelet_map import read_road_network  # noqa: E402

CROSS_MARGIN_M = 0.4
IN_PATH_M = 1.6
FREE_GAP_M = 50.0
MOVING_MS = 2.0


@dataclass
class Car:
    id: str
    t: np.ndarray
    xy: np.ndarray
    heading: np.ndarray
    speed: np.ndarray
    noise: np.ndarray
    lane: np.ndarray
    length: float
    #: motion across the lane since the first step (m, + left; the reader's)
    lateral: np.ndarray

    def at(self, time: float) -> int | None:
        k = int(np.argmin(np.abs(self.t - time)))
        return k if abs(self.t[k] - time) < 1e-6 else None


def positions_speed(t: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed from the path's length (0.5 s centred mean) and the noise in it: a step-to-step
    change faster than 8 m/s^2 that turns back within 2 s."""
    path = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    raw = np.gradient(path, t) if len(t) > 1 else np.zeros(len(t))
    kernel = np.ones(5) / 5
    smooth = np.convolve(np.pad(raw, 2, mode="edge"), kernel, mode="valid")
    acc = np.gradient(smooth, t) if len(t) > 1 else np.zeros(len(t))
    noise = np.zeros(len(t), bool)
    hard = np.flatnonzero(np.abs(acc) > 8.0)
    for k in hard:
        back = hard[(hard > k) & (t[hard] - t[k] <= 2.0) & (np.sign(acc[hard]) != np.sign(acc[k]))]
        if len(back):
            noise[max(k - 3, 0):back[-1] + 4] = True
    return smooth, noise


def cars_of(recording) -> list[Car]:
    found = []
    for tr in recording.tracks:
        xy = np.column_stack([tr.x, tr.y])
        speed, noise = positions_speed(tr.t, xy)
        found.append(Car(tr.id, tr.t, xy, np.asarray(tr.heading, float), speed, noise,
                         np.asarray(tr.lane).astype(str), tr.length_m,
                         np.asarray(tr.lateral if len(tr.lateral) == len(tr.t)
                                    else np.full(len(tr.t), np.nan), float)))
    return found


def signed_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance of points from a polyline (in its direction), + on its left; the line runs
    on 30 m straight past both ends, so a point beyond them is measured square to it."""
    first, last = line[1] - line[0], line[-1] - line[-2]
    line = np.vstack([line[0] - 30 * first / max(np.hypot(*first), 1e-9), line,
                      line[-1] + 30 * last / max(np.hypot(*last), 1e-9)])
    best = np.full(len(points), np.inf)
    signed = np.zeros(len(points))
    for a, b in zip(line[:-1], line[1:], strict=True):
        ab = b - a
        u = np.clip(((points - a) @ ab) / max(ab @ ab, 1e-9), 0, 1)
        near = a + u[:, None] * ab
        d = np.hypot(*(points - near).T)
        side = np.sign(ab[0] * (points[:, 1] - a[1]) - ab[1] * (points[:, 0] - a[0]))
        better = d < best
        best[better], signed[better] = d[better], (d * side)[better]
    return signed


def path_ahead(car: Car, k: int) -> np.ndarray:
    """The path the car drives from step ``k``, extended 80 m along its last heading."""
    rest = car.xy[k:]
    h = car.heading[-1]
    return np.vstack([rest, rest[-1] + 80.0 * np.array([np.cos(h), np.sin(h)])])


def along_path(path: np.ndarray, point: np.ndarray) -> tuple[float, float, float]:
    """(distance along ``path`` to the point's projection, distance off it, path heading)."""
    seg = np.diff(path, axis=0)
    lengths = np.hypot(*seg.T)
    ok = lengths > 1e-6
    seg, lengths, starts = seg[ok], lengths[ok], path[:-1][ok]
    u = np.clip(np.einsum("ij,ij->i", point - starts, seg) / lengths**2, 0, 1)
    d = np.hypot(*(starts + u[:, None] * seg - point).T)
    j = int(np.argmin(d))
    before = float(lengths[:j].sum()) + u[j] * lengths[j]
    return before, float(d[j]), float(np.arctan2(seg[j, 1], seg[j, 0]))


def lead_of(cars: list[Car], i: int, k: int) -> tuple[int, float] | None:
    """The nearest car in car ``i``'s path ahead at its step ``k``, and the bumper gap."""
    me = cars[i]
    path = path_ahead(me, k)
    best = None
    for j, other in enumerate(cars):
        m = other.at(float(me.t[k])) if j != i else None
        if m is None:
            continue
        if np.hypot(*(other.xy[m] - me.xy[k])) > 90:
            continue
        ahead, off, course = along_path(path, other.xy[m])
        turn = abs(np.angle(np.exp(1j * (other.heading[m] - course))))
        gap = ahead - (me.length + other.length) / 2
        if off <= IN_PATH_M and turn < np.radians(45) and ahead > 0.5 and gap > -1.0 \
                and (best is None or gap < best[1]):
            best = (j, max(gap, 0.0))
    return best


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1, strict=True))


def lane_changes(cars: list[Car], strips: dict, junctions: set[str]) -> list[dict]:
    found = []
    for car in cars:
        for k in np.flatnonzero(car.lane[1:] != car.lane[:-1]) + 1:
            old, new = car.lane[k - 1], car.lane[k]
            border, side = _border(strips, old, new)
            if border is None:
                continue
            near = np.abs(car.t - car.t[k]) <= 3.0
            d = signed_distance(car.xy, border) * side  # + on the old lane's side
            before = float(d[near & (np.arange(len(d)) < k)].max(initial=-9))
            after = float(-d[near & (np.arange(len(d)) >= k)].min(initial=9))
            window = np.flatnonzero(near)
            turn = float(np.degrees(np.ptp(np.unwrap(car.heading[window]))))
            sideways = car.lateral[window]
            held = float(sideways[-1] - sideways[0]) if len(window) else 0.0
            found.append({"car": car.id, "k": int(k), "t": float(car.t[k]), "old": old,
                          "new": new, "old_side_m": round(before, 2),
                          "new_side_m": round(after, 2), "turn_deg": round(turn, 1),
                          "junction": old in junctions or new in junctions,
                          "sideways_m": round(held, 2),
                          "direction": "Left" if side < 0 else "Right",
                          "speed": round(float(car.speed[k]), 1)})
    return found


def _border(strips: dict, old: str, new: str) -> tuple[np.ndarray | None, int]:
    """The old lanelet's border with the new one (a same-direction neighbour of it, or of its
    predecessor or successor) and the side the old lane lies on (+1: left of the border)."""
    chain = [old, *strips[old].successors, *strips[old].predecessors] if old in strips else []
    for name in chain:
        strip = strips.get(name)
        if strip is None:
            continue
        targets = {new, *strips[new].predecessors, *strips[new].successors} if new in strips \
            else {new}
        if strip.left_neighbour in targets and strip.left_same_direction:
            return strip.left, -1  # the old lane lies right of its left border
        if strip.right_neighbour in targets and strip.right_same_direction:
            return strip.right, 1
    return None, 0


def following(cars: list[Car]) -> tuple[list[dict], dict]:
    """Runs of one lead in the path within 50 m, both moving; and each car's lead per step."""
    leads = {}
    runs_found = []
    for i, car in enumerate(cars):
        per_step = [lead_of(cars, i, k) for k in range(len(car.t))]
        leads[i] = per_step
        ids = np.array([-1 if p is None or p[1] > FREE_GAP_M else p[0] for p in per_step])
        for j in set(ids[ids >= 0].tolist()):
            lead = cars[j]
            moving = np.array([car.speed[k] >= MOVING_MS and (m := lead.at(car.t[k])) is not None
                               and lead.speed[m] >= MOVING_MS for k in range(len(car.t))])
            for a, b in runs((ids == j) & moving):
                if car.t[b] - car.t[a] >= 4.0 - 1e-6:
                    runs_found.append({"ego": car.id, "lead": lead.id, "start_s": float(car.t[a]),
                                       "end_s": float(car.t[b]),
                                       "gap_m": round(float(per_step[a][1]), 1)})
    return runs_found, leads


def seen_ahead(cars: list[Car], car: Car, k: int) -> bool:
    """Whether the recording covers the road 50 m ahead of the car's front: some car drove
    within 3 m of that point of its path at some time."""
    path = path_ahead(car, k)
    lengths = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    want = FREE_GAP_M + car.length / 2
    point = np.array([np.interp(want, lengths, path[:, 0]), np.interp(want, lengths, path[:, 1])])
    return any(np.min(np.hypot(*(other.xy - point).T)) < 3.0 for other in cars)


def free_rides(cars: list[Car], leads: dict, changes: list[dict]) -> list[dict]:
    found = []
    for i, car in enumerate(cars):
        own = [c["t"] for c in changes if c["car"] == car.id and _real(c)]
        free = np.array([car.speed[k] >= MOVING_MS and (leads[i][k] is None
                         or leads[i][k][1] > FREE_GAP_M) and seen_ahead(cars, car, k)
                         for k in range(len(car.t))])
        for t in own:
            free &= np.abs(car.t - t) > 2.0
        for a, b in runs(free):
            if car.t[b] - car.t[a] < 4.0 - 1e-6:
                continue
            slots = _slots(cars, i, a)
            ahead = leads[i][a]
            behind = [(p[1], cars[j].id) for j, other in enumerate(cars)
                      if (m := other.at(float(car.t[a]))) is not None
                      and (p := leads[j][m]) is not None and p[0] == i and p[1] <= 80]
            found.append({"ego": car.id, "start_s": float(car.t[a]), "end_s": float(car.t[b]),
                          "centre_ahead": cars[ahead[0]].id if ahead and ahead[1] <= 80
                          else None,
                          "centre_behind": min(behind)[1] if behind else None,
                          "ahead": slots[0], "behind": slots[1],
                          "lane": car.lane[a], "speed": round(float(car.speed[a]), 1)})
    return found


def _slots(cars: list[Car], i: int, k: int) -> tuple[list[str], list[str]]:
    """Cars within 80 m ahead and behind in the ego's lane or one beside it, heading its way."""
    me = cars[i]
    h = np.array([np.cos(me.heading[k]), np.sin(me.heading[k])])
    ahead, behind = [], []
    for j, other in enumerate(cars):
        m = other.at(float(me.t[k])) if j != i else None
        if m is None or abs(np.angle(np.exp(1j * (other.heading[m] - me.heading[k])))) > 0.8:
            continue
        rel = other.xy[m] - me.xy[k]
        along, across = float(rel @ h), abs(float(rel[0] * h[1] - rel[1] * h[0]))
        gap = abs(along) - (me.length + other.length) / 2
        if across < 5.5 and gap <= 80:
            (ahead if along > 0 else behind).append(other.id)
    return ahead, behind


def _real(change: dict) -> bool:
    return change["old_side_m"] >= CROSS_MARGIN_M and change["new_side_m"] >= CROSS_MARGIN_M \
        and change["turn_deg"] < 20 and not change["junction"] and change["speed"] >= 1.0 \
        and not abs(change["sideways_m"]) < 1.5  # moved across, held (NaN: not known)


def brakes(cars: list[Car], leads: dict) -> list[dict]:
    found = []
    for i, ego in enumerate(cars):
        for j in {p[0] for p in leads[i] if p is not None and p[1] <= FREE_GAP_M}:
            lead = cars[j]
            clean = np.where(lead.noise, np.nan, lead.speed)
            good = np.isfinite(clean)
            if good.sum() < 10:
                continue
            v = np.interp(lead.t, lead.t[good], clean[good])
            falling = np.gradient(v, lead.t) < -0.5
            for a, b in runs(falling):
                drop = v[a] - v[b]
                hardest = max((v[k] - v[(lead.t > lead.t[k]) & (lead.t <= lead.t[k] + 1.0)
                                      & (np.arange(len(v)) <= b)].min(initial=v[k])
                               for k in range(a, b + 1)), default=0.0)
                k = ego.at(float(lead.t[a]))
                if drop < 2.0 or hardest < 2.0 or v[a] < 3.0 or k is None:
                    continue
                behind = leads[i][k]
                found.append({"ego": ego.id, "lead": lead.id, "start_s": float(lead.t[a]),
                              "end_s": float(lead.t[b]), "drop": round(float(drop), 1),
                              "hardest": round(float(hardest), 1),
                              "lead_in_path": behind is not None and behind[0] == j
                              and behind[1] <= FREE_GAP_M,
                              "ego_speed": round(float(ego.speed[k]), 1),
                              "noise_in_lead": bool(lead.noise[a:b + 1].any())})
    return found


def _state(light, t: float) -> str | None:
    return next((p.state for p in light.phases if p.start_s <= t < p.end_s), None)


def _movement(car: Car, k: int) -> tuple[str, float]:
    """left / straight / right from the heading change from 1 s before step ``k`` to 30 m of
    path past it (or the track's end), and that change (deg, + left)."""
    path = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(car.xy, axis=0).T))])
    a = int(np.searchsorted(car.t, car.t[k] - 1.0))
    b = min(int(np.searchsorted(path, path[k] + 30.0)), len(path) - 1)
    turn = float(np.degrees(np.unwrap(car.heading[a:b + 1])[-1] - car.heading[a])) if b > a \
        else 0.0
    name = "straight" if abs(turn) <= 20 else "right" if turn <= -30 else \
        "left" if turn >= 30 else "unclear"
    return name, round(turn, 1)


def stop_lines(cars: list[Car], recording) -> list[dict]:
    """Each front crossing a stop line, and each stop near one, with the colours of every
    light of that lane then (the car's movement decides which one counts)."""
    found = []
    for car in cars:
        front = car.xy + car.length / 2 * np.column_stack([np.cos(car.heading),
                                                            np.sin(car.heading)])
        for light in recording.lights:
            for lane, x0, y0, x1, y1 in light.stop_lines:
                a, b = np.array([x0, y0]), np.array([x1, y1])
                along = np.array([-(b - a)[1], (b - a)[0]]) / max(np.hypot(*(b - a)), 1e-9)
                ahead = (a + b) / 2 @ along - front @ along
                beside = np.abs((front - (a + b) / 2) @ np.array([along[1], -along[0]]))
                near = beside <= np.hypot(*(b - a)) / 2 + 1.0
                cross = np.flatnonzero(near[:-1] & (ahead[:-1] > 0) & (ahead[1:] <= 0)
                                       & (car.lane[:-1] == lane))
                for k in cross[:1]:
                    move, turn = _movement(car, int(k) + 1)
                    found.append({"car": car.id, "kind": "cross", "t": float(car.t[k + 1]),
                                  "light": light.id, "for": light.direction, "lane": lane,
                                  "colour": _state(light, float(car.t[k + 1])), "move": move,
                                  "turn_deg": turn, "approach_m": round(float(ahead[0]), 1),
                                  "after_m": round(float(-ahead[-1]), 1),
                                  "speed": round(float(car.speed[k]), 1)})
                stopped = np.flatnonzero(near & (ahead >= -2) & (ahead <= 40)
                                         & (car.speed < 0.5) & (car.lane == lane))
                for k in stopped[:1]:
                    move, turn = _movement(car, int(k))
                    found.append({"car": car.id, "kind": "stop", "t": float(car.t[k]),
                                  "light": light.id, "for": light.direction, "lane": lane,
                                  "colour": _state(light, float(car.t[k])), "move": move,
                                  "turn_deg": turn, "to_line_m": round(float(ahead[k]), 1),
                                  "max_speed_before": round(float(car.speed[:k + 1].max()), 1)})
    return found


def in_lane(cars: list[Car], recording) -> list[dict]:
    """Stretches of 3 s or more off junctions and light approaches, faster than 2 m/s."""
    lit = {lane for light in recording.lights for lane in light.lanes}
    skip = set(recording.junction_lanes) | lit | {""}
    found = []
    for car in cars:
        ok = ~np.isin(car.lane, list(skip)) & (car.speed >= 2.0)
        for a, b in runs(ok):
            if car.t[b] - car.t[a] >= 3.0 - 1e-6:
                found.append({"car": car.id, "start_s": float(car.t[a]), "end_s": float(car.t[b]),
                              "turn_deg": round(float(np.degrees(np.ptp(np.unwrap(
                                  car.heading[a:b + 1])))), 1),
                              "lanes": list(dict.fromkeys(car.lane[a:b + 1].tolist()))})
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("file", type=Path)
    args = parser.parse_args()
    recording = next(iter(read_recordings(args.file)))
    network = read_road_network(args.file)
    strips = {s.id: s for s in network.strips}
    cars = cars_of(recording)
    changes = lane_changes(cars, strips, set(recording.junction_lanes))
    follows, leads = following(cars)
    found = {"lane_changes": changes, "following": follows,
             "free": free_rides(cars, leads, changes), "brakes": brakes(cars, leads),
             "stop_lines": stop_lines(cars, recording), "in_lane": in_lane(cars, recording)}
    print(json.dumps(found, indent=1, default=str))


if __name__ == "__main__":
    main()

"""Highway sample files: one ``<CLASS>_BINS_VALUES.npy`` per class, cells as strings.

Fields are drawn jointly, as in the real data (thesis §4.3, Fig. 4.16): final speeds follow
initial speeds, gaps follow speed through a time headway, braking depth follows intensity
and duration. The first rows of each file are edge cases a parser must get right.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from scenweave.ingest.layouts import HighwayLayouts, load_layouts

Columns = dict[str, np.ndarray]
VEHICLE_TYPES = np.array(["Car", "Truck", "Van", "Motorcycle"], dtype=object)
VEHICLE_WEIGHTS = [0.78, 0.14, 0.06, 0.02]


def write_highway_samples(out_dir: Path, seed: int, per_class: int,
                          layouts: HighwayLayouts | None = None) -> list[Path]:
    """Write one file per highway class into ``out_dir``; return the paths."""
    layouts = layouts or load_layouts()
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for offset, (code, layout) in enumerate(sorted(layouts.classes.items())):
        rng = np.random.default_rng([seed, offset])
        columns = GENERATORS[layout.family](rng, per_class, code)
        table = np.empty((per_class, len(layout.columns)), dtype=object)
        for index, name in enumerate(layout.names):
            table[:, index] = _as_strings(columns[name])
        path = out_dir / f"{code}_BINS_VALUES.npy"
        np.save(path, table, allow_pickle=True)
        paths.append(path)
    return paths


def _as_strings(values: np.ndarray) -> np.ndarray:
    if values.dtype == object:
        return values
    return np.array([f"{v:.2f}".rstrip("0").rstrip(".") if v != int(v) else f"{v:.1f}"
                     for v in values], dtype=object)


def _yes_no(rng: np.random.Generator, n: int, p_yes: float = 0.6) -> np.ndarray:
    return np.where(rng.random(n) < p_yes, "Yes", "No").astype(object)


def _left_right(rng: np.random.Generator, n: int, p_left: float = 0.55) -> np.ndarray:
    return np.where(rng.random(n) < p_left, "Left", "Right").astype(object)


def _vehicle_types(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.choice(VEHICLE_TYPES, size=n, p=VEHICLE_WEIGHTS)


def _speeds_kmh(rng: np.random.Generator, n: int, low: float, high: float) -> np.ndarray:
    return np.round(rng.uniform(low, high, n), 1)


def _brake(rng: np.random.Generator, n: int, code: str) -> Columns:
    busy = code == "BR_BK"
    ego = _speeds_kmh(rng, n, 40 if busy else 60, 120 if busy else 135)
    lead = np.clip(np.round(ego + rng.normal(-4, 5, n), 1), 5, None)
    intensity = np.round(rng.beta(2, 4, n), 2)
    duration = np.round(np.clip(rng.lognormal(0.6, 0.45, n), 0.3, 8), 1)
    delta = -np.round(intensity * 8.0 * duration * 3.6 * rng.uniform(0.5, 1.0, n), 2)
    headway = rng.uniform(0.7, 2.5, n)
    distance = np.round(np.clip(ego / 3.6 * headway, 5, 120), 1)
    if n >= 2:  # edge rows: the lead brakes to a standstill (lead + delta < 0); shortest burst
        delta[0], intensity[0] = -(lead[0] + 15.0), 1.0
        duration[0] = max(duration[0], np.ceil(lead[0] / 3.6 / 8.0 * 10) / 10)  # <= 8 m/s^2
        duration[1], delta[1] = 0.1, -0.08
    return {"ego_vel_kmh": ego, "lead_vel_kmh": lead, "duration_s": duration,
            "delta_vel_kmh": delta, "npc_distance_m": distance, "brake_intensity": intensity,
            "other_dir_traffic": _yes_no(rng, n), "lead_vehicle_type": _vehicle_types(rng, n)}


def _cut(rng: np.random.Generator, n: int, code: str) -> Columns:
    behind = code.endswith("B")
    cut_out = code.startswith("COUT")
    ego = _speeds_kmh(rng, n, 70, 130)
    if cut_out:  # thesis Table 4.3: REL and DELTA very small, the NPC nearly at ego speed
        rel = np.round(rng.uniform(0.1, 0.9, n) * rng.choice([-1, 1], n), 2)
        delta = np.round(rng.uniform(0.1, 0.9, n) * rng.choice([-1, 1], n), 2)
    else:
        rel = np.round(rng.normal(3 if behind else -3, 5, n), 1)
        delta = np.round(rng.normal(0, 3, n), 1)
    gap = np.round(rng.uniform(6, 45, n), 1)
    distance = -gap if behind else gap
    duration = np.round(rng.uniform(2.0, 6.0, n), 1)
    if code == "CINB":  # the merging car ends behind the ego: it gains at most gap - 9 m
        gap = np.maximum(gap, 12.0)
        distance = -gap
        gained_kmh = np.maximum(rel + delta / 2, 0.0)
        most_kmh = np.maximum((gap - 9.0) / duration * 3.6, 0.0)
        rel = np.where(gained_kmh > most_kmh, np.round(most_kmh - delta / 2 - 0.1, 1), rel)
    if n >= 1:  # edge row: the cutter at exactly the ego speed
        rel[0], delta[0] = 0.0, 0.0
    return {"ego_vel_kmh": ego, "cutter_vel_kmh": rel, "delta_vel_kmh": delta,
            "duration_s": duration, "npc_distance_m": distance,
            "other_dir_traffic": _yes_no(rng, n), "direction": _left_right(rng, n),
            "lead_vehicle_type": _vehicle_types(rng, n)}


def _lane_change(rng: np.random.Generator, n: int, code: str) -> Columns:
    begin = _speeds_kmh(rng, n, 95, 135)
    end = np.round(begin + rng.normal(2.5 if code == "LCF" else 1.0, 2.0, n), 1)
    duration = np.round(np.clip(rng.normal(4.0, 0.6, n), 2.5, 6.0), 1)
    return {"ego_vel_begin_kmh": begin, "ego_vel_end_kmh": end, "duration_s": duration,
            "other_dir_traffic": _yes_no(rng, n, 0.3), "direction": _left_right(rng, n)}


def _follow(rng: np.random.Generator, n: int, code: str) -> Columns:
    behaviour = rng.choice(np.array(["B1", "B2", "B3", "B4"], dtype=object), n,
                           p=[0.25, 0.25, 0.35, 0.15])
    duration = np.round(rng.uniform(2.0, 10.0, n), 1)
    ego0 = _speeds_kmh(rng, n, 50, 130)
    closing = np.select([behaviour == "B1", behaviour == "B2"],
                        [rng.uniform(-12, -3, n), rng.uniform(3, 12, n)], rng.normal(0, 1, n))
    # B1/B2: the initial speed difference already points the way the gap goes
    offset = np.where(np.isin(behaviour, ["B1", "B2"]), -np.sign(closing) * np.abs(
        rng.normal(0, 1.5, n)), rng.normal(0, 2, n))
    lead0 = ego0 + offset
    lead1 = lead0 - closing / 2
    ego1 = ego0 + closing / 2
    gap0 = np.where(behaviour == "B4", rng.uniform(55, 110, n),
                    np.clip(ego0 / 3.6 * rng.uniform(0.8, 2.0, n), 8, 49))
    mean_rel_ms = ((ego0 + ego1) - (lead0 + lead1)) / 2 / 3.6
    # an ego faster than the other car closes in on it ahead (FLF) and draws away from it
    # behind (FLB): the end gap follows from the speeds, or no replay can show both; where
    # the drawn speeds would bring the cars closer than 5 m, the other car's end speed gives way
    closes_in = 1.0 if code == "FLF" else -1.0
    shrinking_ms = np.minimum(closes_in * mean_rel_ms, (gap0 - 5.0) / duration)
    mean_rel_ms = closes_in * shrinking_ms
    lead1 = (ego0 + ego1) - mean_rel_ms * 3.6 * 2 - lead0
    gap1 = gap0 - closes_in * mean_rel_ms * duration
    travelled = (lead0 + lead1) / 2 / 3.6 * duration
    return {"ego_vel_begin_kmh": np.round(ego0, 1), "ego_vel_end_kmh": np.round(ego1, 1),
            "lead_vel_begin_kmh": np.round(lead0, 1), "lead_vel_end_kmh": np.round(lead1, 1),
            "npc_distance_begin_m": np.round(gap0, 1), "npc_distance_end_m": np.round(gap1, 1),
            "lead_dist_traveled_m": np.round(travelled, 1), "duration_s": duration,
            "other_dir_traffic": _yes_no(rng, n), "behavior_type": behaviour,
            "lead_vehicle_type": _vehicle_types(rng, n)}


def _free_ride(rng: np.random.Generator, n: int, code: str) -> Columns:
    behind = code == "FRB"
    duration = np.round(rng.uniform(4.0, 20.0, n), 1)
    ego0 = _speeds_kmh(rng, n, 80, 135)
    ego1 = np.round(ego0 + rng.normal(0, 3, n), 1)
    columns: Columns = {
        "ego_vel_begin_kmh": ego0, "ego_vel_end_kmh": ego1,
        "ego_dist_traveled_m": np.round((ego0 + ego1) / 2 / 3.6 * duration, 1),
        "ego_acc_mean_ms2": np.round((ego1 - ego0) / 3.6 / duration, 3),
        "duration_s": duration, "ego_lane_index": rng.integers(1, 4, n).astype(float),
        "lane_count": np.full(n, 4.0), "ego_lat_offset_m": np.round(rng.normal(0, 0.2, n), 2),
        "speed_limit_kmh": np.full(n, 130.0),
        "driving_side": np.full(n, "Right", dtype=object),
        "other_dir_traffic": _yes_no(rng, n),
    }
    for slot, p_present in (("center", 0.7), ("right", 0.5), ("left", 0.5)):
        columns.update(_slot(rng, n, slot, p_present, ego0, ego1, duration, behind))
    if n >= 1:  # edge row: nobody around, every slot a sentinel (position -1, speed -3.6)
        for slot in ("center", "right", "left"):
            for key, value in (("posx_begin_m", -1.0), ("posx_end_m", -1.0),
                               ("vel_begin_ms", -3.6), ("vel_end_ms", -3.6)):
                columns[f"{slot}_{key}"][0] = value
            columns[f"{slot}_vehicle_type"][0] = "None"
    return columns


def _slot(rng: np.random.Generator, n: int, slot: str, p_present: float, ego0_kmh: np.ndarray,
          ego1_kmh: np.ndarray, duration: np.ndarray, behind: bool) -> Columns:
    present = rng.random(n) < p_present
    sign = -1 if behind else 1
    ego0, ego1 = ego0_kmh / 3.6, ego1_kmh / 3.6
    # the slot's speed relative to the ego keeps its sign over the record, so the gap only
    # grows or only shrinks (both change speed linearly), and it ends no closer than 10 m: the
    # end gap follows from the speeds and no car drives through the ego's
    rel0 = np.clip(ego0 + rng.normal(0, 2.5, n), 5, None) - ego0
    rel1 = rel0 + rng.normal(0, 0.5, n)
    rel1 = np.where(np.sign(rel1) == np.sign(rel0), rel1, 0.0)
    gap0 = rng.uniform(15, 90, n)
    closing = -sign * (rel0 + rel1) / 2
    limit = (gap0 - 10.0) / duration
    scale = np.where(closing > limit, limit / np.where(closing > 0, closing, 1.0), 1.0)
    rel0, rel1 = rel0 * scale, rel1 * scale
    speed0, speed1 = ego0 + rel0, ego1 + rel1
    gap1 = gap0 + sign * (rel0 + rel1) / 2 * duration
    absent_speed = rng.choice([-3.6, -1.0], n)
    return {
        f"{slot}_posx_begin_m": np.where(present, np.round(sign * gap0, 1), -1.0),
        f"{slot}_posx_end_m": np.where(present, np.round(sign * gap1, 1), -1.0),
        f"{slot}_vel_begin_ms": np.where(present, np.round(speed0, 2), absent_speed),
        f"{slot}_vel_end_ms": np.where(present, np.round(speed1, 2), absent_speed),
        f"{slot}_vehicle_type": np.where(present, _vehicle_types(rng, n), "None").astype(object),
    }


GENERATORS: dict[str, Callable[[np.random.Generator, int, str], Columns]] = {
    "BRAKE": _brake, "CUT": _cut, "LC": _lane_change, "FL": _follow, "FR": _free_ride,
}

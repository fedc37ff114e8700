"""The original NGSIM trajectory table (US-101, I-80, Lankershim, Peachtree).

One row per vehicle and frame (10 frames/s), in feet and ft/s: ``Vehicle_ID, Frame_ID,
Total_Frames, Global_Time, Local_X, Local_Y, ..., v_Length, v_Width, v_Class, v_Vel, v_Acc,
Lane_ID, ...``; some versions add ``Location, O_Zone, D_Zone, Int_ID, Section_ID, Direction,
Movement``. Header names are matched whatever their case, spacing or underscores; comma,
semicolon, tab or blank separated; the headerless ``trajectories-*.txt`` of the original
release is read in its documented column order.

What the reader makes of it:

- ``Local_Y``/``Local_X`` are the *front centre* of the vehicle; positions and ``s`` are moved
  back by half a length along the direction of travel, so ``s`` is the box centre as in the
  other readers. On the freeways all traffic drives towards +``Local_Y``; where a
  ``Direction`` column exists (the arterials) each direction's axis and sign come from where
  its vehicles actually go, so ``s`` grows along travel for southbound cars too.
- NGSIM reuses vehicle ids across its periods: a vehicle id's rows become separate tracks
  wherever the frames are not contiguous (ids ``"<id>-1"``, ``"<id>-2"``, ...).
- ``Lane_ID`` 1 is the leftmost lane; ``lane_index`` is ``Lane_ID`` for 1-9 (on the
  freeways 6-8 are the auxiliary lane and ramps, right of lane 5) and NaN for the arterials'
  turn-bay and intersection codes (0, 10 and above), which are not ordered across the road.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from scenweave.mining.readers._common import (
    FOOT_M,
    TableSpec,
    delimiter_of,
    first_line,
    header_keys,
    heading_from_motion,
    load_table,
    sort_tracks,
    split_line,
)
from scenweave.mining.tracks import Recording, Track

NAME = "ngsim-csv"

#: the columns of the 2006 release in order (the headerless .txt files have the first 18)
STANDARD_COLUMNS = (
    "vehicleid", "frameid", "totalframes", "globaltime", "localx", "localy", "globalx",
    "globaly", "vlength", "vwidth", "vclass", "vvel", "vacc", "laneid", "preceding",
    "following", "spaceheadway", "timeheadway", "location", "ozone", "dzone", "intid",
    "sectionid", "direction", "movement",
)
#: spellings of the same column in other versions -> the name above
ALIASES = {"preceeding": "preceding", "vehicleclass": "vclass", "vehiclelength": "vlength",
           "vehiclewidth": "vwidth", "vvelocity": "vvel", "frame": "frameid"}
#: the numbers every row must have
NEEDED = ("vehicleid", "frameid", "localx", "localy", "vlength", "vwidth", "vclass", "vvel",
          "laneid")
CLASSES = {1: "motorcycle", 2: "car", 3: "truck"}
FRAME_S = 0.1


SPEC = TableSpec(numeric=NEEDED, optional=("globaltime", "direction"), known=STANDARD_COLUMNS,
                 aliases=ALIASES, headerless=STANDARD_COLUMNS)


def sniff(path: Path) -> bool:
    """An NGSIM table: a header naming a vehicle id, a frame id and Local_Y, or a headerless
    ``.txt`` whose first line holds 18 or 25 numbers."""
    if path.suffix.lower() not in (".csv", ".txt"):
        return False
    line = first_line(path)
    fields = split_line(line, delimiter_of(line))
    names = header_keys(fields, ALIASES)
    if names is None:
        return path.suffix.lower() == ".txt" and len(fields) in (18, 25)
    return {"vehicleid", "frameid", "localy"} <= set(names)


def _frame_s(cols: dict[str, np.ndarray], order: np.ndarray) -> float:
    """The time step: from Global_Time (ms) over consecutive frames where the file has it."""
    if "globaltime" not in cols:
        return FRAME_S
    frames, ms = cols["frameid"][order], cols["globaltime"][order]
    same = np.diff(cols["vehicleid"][order]) == 0
    step = same & (np.diff(frames) == 1)
    if not step.any():
        return FRAME_S
    return round(float(np.median(np.diff(ms)[step])) / 1000.0, 4) or FRAME_S


def _segments(vid: np.ndarray, frame: np.ndarray) -> list[np.ndarray]:
    """Row indices (sorted by vehicle, frame) of each run of contiguous frames of one id."""
    breaks = (np.diff(vid) != 0) | (np.diff(frame) != 1)
    return np.split(np.arange(len(vid)), np.flatnonzero(breaks) + 1)


def _travel_axes(cols: dict[str, np.ndarray], segments: list[np.ndarray]
                 ) -> dict[float, tuple[str, float]]:
    """Per Direction code (one group without the column): the axis its vehicles travel along
    (``"localy"`` or ``"localx"``) and the sign of travel on it, from their summed motion."""
    groups = cols.get("direction", np.zeros_like(cols["vehicleid"]))
    motion: dict[float, np.ndarray] = {}
    for seg in segments:
        d = np.array([cols["localx"][seg[-1]] - cols["localx"][seg[0]],
                      cols["localy"][seg[-1]] - cols["localy"][seg[0]]])
        motion[groups[seg[0]]] = motion.get(groups[seg[0]], np.zeros(2)) + d
    axes = {}
    for group, (dx, dy) in motion.items():
        along_x = abs(dx) > abs(dy)
        component = dx if along_x else dy
        axes[group] = ("localx" if along_x else "localy", -1.0 if component < 0 else 1.0)
    return axes


def _lane_index(lane_id: np.ndarray) -> np.ndarray:
    return np.where((lane_id >= 1) & (lane_id <= 9), lane_id, np.nan)


def _track(track_id: str, seg: np.ndarray, cols: dict[str, np.ndarray], axis: tuple[str, float],
           t: np.ndarray) -> Track:
    name, sign = axis
    length = float(np.median(cols["vlength"][seg])) * FOOT_M
    front = {k: cols[k][seg] * FOOT_M for k in ("localx", "localy")}
    centre = dict(front)
    centre[name] = front[name] - sign * length / 2
    x, y = centre["localx"], centre["localy"]
    heading = heading_from_motion(x, y, t)
    default = np.arctan2(sign if name == "localy" else 0.0, sign if name == "localx" else 0.0)
    lane_id = cols["laneid"][seg]
    return Track(
        id=track_id, length_m=length, width_m=float(np.median(cols["vwidth"][seg])) * FOOT_M,
        vehicle_type=CLASSES.get(int(cols["vclass"][seg[0]]), "car"),
        t=t, x=x, y=y, heading=np.where(np.isnan(heading), default, heading),
        speed=cols["vvel"][seg] * FOOT_M, s=sign * centre[name],
        lane=lane_id.astype(int).astype(str), lane_index=_lane_index(lane_id))


def _segment_ids(vid: np.ndarray, segments: list[np.ndarray]) -> list[str]:
    """``"12"`` for a vehicle seen once, ``"12-1"``, ``"12-2"`` for one whose frames break."""
    per_vehicle = Counter(int(vid[seg[0]]) for seg in segments)
    seen: Counter[int] = Counter()
    ids = []
    for seg in segments:
        v = int(vid[seg[0]])
        seen[v] += 1
        ids.append(str(v) if per_vehicle[v] == 1 else f"{v}-{seen[v]}")
    return ids


def read(path: Path) -> Recording:
    """The file's tracks; a row that does not parse is a warning naming its line."""
    path = Path(path)
    warnings: list[str] = []
    cols = load_table(path, SPEC, warnings)
    if not len(cols["vehicleid"]):
        warnings.append(f"{path.name}: no vehicle rows")
        return Recording(source=str(path), dt=FRAME_S, tracks=[], reader=NAME,
                         warnings=warnings)
    order = np.lexsort((cols["frameid"], cols["vehicleid"]))
    dt = _frame_s(cols, order)
    duplicate = np.zeros(len(order), bool)
    duplicate[1:] = (np.diff(cols["vehicleid"][order]) == 0) & (
        np.diff(cols["frameid"][order]) == 0)
    if duplicate.any():
        warnings.append(f"{path.name}: {int(duplicate.sum())} repeated vehicle/frame rows "
                        "skipped")
    order = order[~duplicate]
    cols = {k: v[order] for k, v in cols.items()}
    segments = _segments(cols["vehicleid"], cols["frameid"])
    short = [seg for seg in segments if len(seg) < 2]
    if short:
        warnings.append(f"{path.name}: {len(short)} vehicle(s) seen in one frame only skipped")
    axes = _travel_axes(cols, segments)
    groups = cols.get("direction", np.zeros_like(cols["vehicleid"]))
    first_frame = cols["frameid"].min()
    tracks = [
        _track(track_id, seg, cols, axes[groups[seg[0]]],
               (cols["frameid"][seg] - first_frame) * dt)
        for track_id, seg in zip(_segment_ids(cols["vehicleid"], segments), segments,
                                 strict=True)
        if len(seg) >= 2
    ]
    return Recording(source=str(path), dt=dt, tracks=sort_tracks(tracks), reader=NAME,
                     warnings=warnings)

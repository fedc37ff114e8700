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
    load_table,
    segment_headings,
    sort_tracks,
    split_line,
)
from scenweave.mining.tracks import Floats, Mask, Recording, Steps, Track

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


def _frame_s(cols: dict[str, np.ndarray], order: Steps) -> float:
    """The time step: from Global_Time (ms) over consecutive frames where the file has it."""
    if "globaltime" not in cols:
        return FRAME_S
    frames, ms = cols["frameid"][order], cols["globaltime"][order]
    same = np.diff(cols["vehicleid"][order]) == 0
    step = same & (np.diff(frames) == 1)
    if not step.any():
        return FRAME_S
    return round(float(np.median(np.diff(ms)[step])) / 1000.0, 4) or FRAME_S


def _segment_starts(vid: Floats, frame: Floats) -> Steps:
    """First row (rows sorted by vehicle, frame) of each run of contiguous frames of one id."""
    breaks = (np.diff(vid) != 0) | (np.diff(frame) != 1)
    return np.r_[0, np.flatnonzero(breaks) + 1]


def _travel_axes(cols: dict[str, np.ndarray], starts: Steps, ends: Steps
                 ) -> tuple[Mask, Floats]:
    """Per row: whether its vehicle travels along Local_X (else Local_Y), and the sign of
    travel on that axis. Decided per Direction code (one group without the column) from the
    summed motion of the group's vehicles."""
    groups = cols.get("direction", np.zeros_like(cols["vehicleid"]))
    along_x, sign = np.zeros(len(groups), bool), np.ones(len(groups))
    seg_group = groups[starts]
    for group in np.unique(seg_group):
        mine = seg_group == group
        dx = float(np.sum(cols["localx"][ends[mine] - 1] - cols["localx"][starts[mine]]))
        dy = float(np.sum(cols["localy"][ends[mine] - 1] - cols["localy"][starts[mine]]))
        rows = groups == group
        along_x[rows] = abs(dx) > abs(dy)
        sign[rows] = -1.0 if (dx if abs(dx) > abs(dy) else dy) < 0 else 1.0
    return along_x, sign


def _segment_ids(vid: Floats, starts: Steps) -> list[str]:
    """``"12"`` for a vehicle seen once, ``"12-1"``, ``"12-2"`` for one whose frames break."""
    vehicles = vid[starts].astype(int)
    per_vehicle = Counter(vehicles.tolist())
    seen: Counter[int] = Counter()
    ids = []
    for v in vehicles.tolist():
        seen[v] += 1
        ids.append(str(v) if per_vehicle[v] == 1 else f"{v}-{seen[v]}")
    return ids


def _rows(cols: dict[str, np.ndarray], starts: Steps, dt: float) -> dict[str, np.ndarray]:
    """Every row's track values at once (rows sorted by vehicle and frame): the front moved
    back to the centre along travel, s, times, heading from the motion."""
    n = len(cols["vehicleid"])
    ends = np.r_[starts[1:], n]
    along_x, sign = _travel_axes(cols, starts, ends)
    length = np.repeat(cols["vlength"][starts], np.diff(np.r_[starts, n])) * FOOT_M
    x, y = cols["localx"] * FOOT_M, cols["localy"] * FOOT_M
    x = np.where(along_x, x - sign * length / 2, x)
    y = np.where(along_x, y, y - sign * length / 2)
    t = (cols["frameid"] - cols["frameid"].min()) * dt
    heading = segment_headings(x, y, t, starts)
    default = np.where(along_x, np.where(sign > 0, 0.0, np.pi), sign * np.pi / 2)
    return {"x": x, "y": y, "t": t, "s": sign * np.where(along_x, x, y),
            "heading": np.where(np.isnan(heading), default, heading),
            "speed": cols["vvel"] * FOOT_M, "lane": cols["laneid"].astype(int).astype(str),
            "lane_index": np.where((cols["laneid"] >= 1) & (cols["laneid"] <= 9),
                                   cols["laneid"], np.nan)}


def _tracks(cols: dict[str, np.ndarray], starts: Steps, dt: float) -> list[Track]:
    """One track per run of contiguous frames that has two or more."""
    values = _rows(cols, starts, dt)
    ends = np.r_[starts[1:], len(cols["vehicleid"])]
    tracks = []
    for track_id, a, b in zip(_segment_ids(cols["vehicleid"], starts), starts, ends,
                              strict=True):
        if b - a < 2:
            continue
        tracks.append(Track(
            id=track_id, length_m=float(cols["vlength"][a]) * FOOT_M,
            width_m=float(cols["vwidth"][a]) * FOOT_M,
            vehicle_type=CLASSES.get(int(cols["vclass"][a]), "car"),
            **{name: v[a:b] for name, v in values.items()}))
    return tracks


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
    cols = {k: v[order[~duplicate]] for k, v in cols.items()}
    starts = _segment_starts(cols["vehicleid"], cols["frameid"])
    single = int(np.sum(np.diff(np.r_[starts, len(cols["vehicleid"])]) < 2))
    if single:
        warnings.append(f"{path.name}: {single} vehicle(s) seen in one frame only skipped")
    return Recording(source=str(path), dt=dt, tracks=sort_tracks(_tracks(cols, starts, dt)),
                     reader=NAME, warnings=warnings)

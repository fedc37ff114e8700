"""The highD drone recordings: ``XX_tracks.csv`` with its ``XX_tracksMeta.csv`` and
``XX_recordingMeta.csv`` (the dataset itself may not be redistributed; the tests use a
fixture written in its documented format).

What the reader makes of it:

- ``x, y`` are the upper-left corner of the bounding box in an image-like frame (y grows
  downwards); ``width`` is the length along x, ``height`` the width. Positions are moved to
  the box centre.
- ``drivingDirection`` 1 drives towards -x (upper half), 2 towards +x (lower half): ``s`` is
  the centre's x, negated for direction 1, so it grows along travel in both.
- ``laneId`` numbers the lanes of both carriageways in one sequence; ``lane_index`` orders
  them from the left of the direction of travel, which for right-hand traffic is the lane
  next to the median, as the recording's lane markings show: each laneId is placed by where
  its vehicles drive between the ``upperLaneMarkings`` / ``lowerLaneMarkings``.
- ``heading`` is the direction of the velocity, ``speed`` its magnitude, in the file's frame.
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import numpy as np

from scenweave.mining.readers._common import (
    TableSpec,
    first_line,
    header_keys,
    load_table,
    skipped_warning,
    sort_tracks,
    split_line,
    vehicle_type,
)
from scenweave.mining.tracks import Floats, Recording, Steps, Track

NAME = "highd"
TRACKS = re.compile(r"^(\d+)_tracks\.csv$", re.IGNORECASE)
COMPANION = re.compile(r"^(\d+)_(tracksMeta|recordingMeta)\.csv$", re.IGNORECASE)

TRACK_COLUMNS = (
    "frame", "id", "x", "y", "width", "height", "xvelocity", "yvelocity", "xacceleration",
    "yacceleration", "frontsightdistance", "backsightdistance", "dhw", "thw", "ttc",
    "precedingxvelocity", "precedingid", "followingid", "leftprecedingid", "leftalongsideid",
    "leftfollowingid", "rightprecedingid", "rightalongsideid", "rightfollowingid", "laneid",
)
TRACKS_SPEC = TableSpec(
    numeric=("frame", "id", "x", "y", "width", "height", "xvelocity", "yvelocity", "laneid"),
    known=TRACK_COLUMNS)
META_SPEC = TableSpec(numeric=("id", "width", "height", "drivingdirection"), text=("class",))
RECORDING_SPEC = TableSpec(numeric=("framerate",),
                           text=("upperlanemarkings", "lowerlanemarkings"))


def sniff(path: Path) -> bool:
    """A ``NN_tracks.csv`` whose header has highD's frame, id, x, y and laneId columns."""
    if not TRACKS.match(path.name):
        return False
    names = header_keys(split_line(first_line(path), ","))
    return names is not None and {"frame", "id", "x", "y", "laneid"} <= set(names)


def companion(path: Path) -> bool:
    """A meta file that belongs to a ``NN_tracks.csv`` beside it (read along with that)."""
    match = COMPANION.match(path.name)
    return match is not None and _sibling(path, match.group(1), "tracks").exists()


def _sibling(path: Path, number: str, kind: str) -> Path:
    return path.with_name(f"{number}_{kind}.csv")


def _markings(text: str) -> Floats:
    return np.sort(np.array([float(v) for v in text.split(";") if v.strip()], dtype=float))


def lane_order(lane_y: dict[int, float], upper: Floats, lower: Floats) -> dict[int, float]:
    """laneId -> index from the left of travel (1 = next to the median), from the typical
    centre y of each lane's vehicles between the markings; NaN for a lane outside them."""
    order = {}
    for lane, y in lane_y.items():
        if len(upper) > 1 and upper[0] <= y <= upper[-1]:
            from_top = int(np.searchsorted(upper, y))
            order[lane] = float(len(upper) - from_top)
        elif len(lower) > 1 and lower[0] <= y <= lower[-1]:
            order[lane] = float(np.searchsorted(lower, y))
        else:
            order[lane] = np.nan
    return order


def _row_lane_index(cols: dict[str, np.ndarray], upper: Floats, lower: Floats) -> Floats:
    """Every row's lane index, from its laneId's place between the markings."""
    lanes = cols["laneid"].astype(int)
    ids = np.unique(lanes)
    centre_y = cols["y"] + cols["height"] / 2
    typical = {int(lane): float(np.median(centre_y[lanes == lane])) for lane in ids}
    order = lane_order(typical, upper, lower)
    return np.array([order[int(lane)] for lane in ids], dtype=float)[
        np.searchsorted(ids, lanes)]


def _meta(path: Path, number: str, warnings: list[str]) -> dict[int, tuple[float, float, str, int]]:
    """Track id -> (length, width, class, drivingDirection) from the tracksMeta file."""
    cols = load_table(_sibling(path, number, "tracksMeta"), META_SPEC, warnings)
    return {int(i): (float(w), float(h), str(c), int(d)) for i, w, h, c, d in zip(
        cols["id"], cols["width"], cols["height"], cols["class"], cols["drivingdirection"],
        strict=True)}


def _recording(path: Path, number: str, warnings: list[str]
               ) -> tuple[float, Floats, Floats]:
    """Frame rate and the sorted upper and lower lane markings (y, m)."""
    cols = load_table(_sibling(path, number, "recordingMeta"), RECORDING_SPEC, warnings)
    if not len(cols["framerate"]):
        raise ValueError(f"{path.name}: the recordingMeta file has no row")
    return (float(cols["framerate"][0]), _markings(cols["upperlanemarkings"][0]),
            _markings(cols["lowerlanemarkings"][0]))


def _track(rows: Steps, cols: dict[str, np.ndarray], meta: tuple[float, float, str, int],
           t: Floats, lane_index: Floats) -> Track:
    length, width, kind, direction = meta
    x = cols["x"][rows] + cols["width"][rows] / 2
    y = cols["y"][rows] + cols["height"][rows] / 2
    vx, vy = cols["xvelocity"][rows], cols["yvelocity"][rows]
    lanes = cols["laneid"][rows].astype(int)
    return Track(
        id=str(int(cols["id"][rows[0]])), length_m=length, width_m=width,
        vehicle_type=vehicle_type(kind) or "car", t=t, x=x, y=y,
        heading=np.arctan2(vy, vx), speed=np.hypot(vx, vy),
        s=-x if direction == 1 else x, lane=lanes.astype(str),
        lane_index=lane_index[rows])


def read(path: Path) -> Recording:
    """One highD recording from its tracks file and the two meta files beside it."""
    path = Path(path)
    named = TRACKS.match(path.name)
    if named is None:
        raise ValueError(f"{path.name}: a highD tracks file is named NN_tracks.csv")
    number = named.group(1)
    warnings: list[str] = []
    fps, upper, lower = _recording(path, number, warnings)
    meta = _meta(path, number, warnings)
    cols = load_table(path, TRACKS_SPEC, warnings)
    order = np.lexsort((cols["frame"], cols["id"]))
    cols = {k: v[order] for k, v in cols.items()}
    lane_index = _row_lane_index(cols, upper, lower)
    t0 = cols["frame"].min() if len(order) else 0.0
    tracks: list[Track] = []
    skipped: Counter[str] = Counter()
    for rows in np.split(np.arange(len(order)), np.flatnonzero(np.diff(cols["id"])) + 1):
        track_id = int(cols["id"][rows[0]]) if len(rows) else None
        if track_id is None or len(rows) < 2:
            continue
        if track_id not in meta:
            warnings.append(f"{path.name}: track {track_id} has no tracksMeta row, skipped")
            continue
        if vehicle_type(meta[track_id][2]) is None:
            skipped[meta[track_id][2].lower()] += 1
            continue
        tracks.append(_track(rows, cols, meta[track_id], (cols["frame"][rows] - t0) / fps,
                             lane_index))
    return Recording(source=str(path), dt=1.0 / fps, tracks=sort_tracks(tracks), reader=NAME,
                     warnings=warnings + skipped_warning(skipped))

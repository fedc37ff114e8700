"""A played scenario as a recording, so the round trip can mine it again: record -> scenario
-> esmini replay -> :class:`Recording` -> the same detectors.

Positions along the road: each car's own path length from where it stood at t = 0, placed
on the ego's path at t = 0 (gaps between two cars of one lane are then measured along that
lane). Lanes: OpenDRIVE lane ids, counted from the road's centre outwards (``-1`` is the
leftmost lane of the right-hand side, in the direction of travel).
"""

from __future__ import annotations

import math

import numpy as np

from scenweave.mining.tracks import Floats, Recording, Track
from scenweave.player import Playback

#: lanes are about this wide on the CARLA highways; it only scales the lateral positions
LANE_WIDTH_M = 3.5
#: the scenario's actors as the record's roles (a free ride's NPC is the car in the ego's lane)
ROLE_OF_ENTITY = {"hero": "ego", "npc": "npc", "npc_center": "npc"}  # a free ride's own lane


def recording_from_playback(playback: Playback, source: str) -> Recording:
    times = np.asarray(playback.times, dtype=float)
    dt = float(np.median(np.diff(times))) if len(times) > 1 else 0.05
    centres = {name: _centres(playback, name) for name in playback.tracks}
    ego_path = centres.get("hero")
    tracks = [_track(playback, name, xy, times, ego_path) for name, xy in centres.items()]
    return Recording(source=source, dt=dt, tracks=tracks, reader="esmini-replay")


def _centres(playback: Playback, name: str) -> Floats:
    """The box centre of ``name`` at every step (esmini reports the reference point)."""
    track, box = playback.tracks[name], playback.boxes.get(name)
    ahead = box.center_ahead if box else 0.0
    h = np.asarray(track["h"], dtype=float)
    return np.column_stack([np.asarray(track["x"]) + ahead * np.cos(h),
                            np.asarray(track["y"]) + ahead * np.sin(h)])


def _track(playback: Playback, name: str, xy: Floats, times: Floats,
           ego_path: Floats | None) -> Track:
    own = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    start = _along(ego_path, xy[0]) if ego_path is not None else 0.0
    lanes = np.asarray(playback.tracks[name]["lane"], dtype=float)
    offsets = np.asarray(playback.tracks[name].get("lane_offset") or np.zeros(len(lanes)),
                         dtype=float)
    box = playback.boxes.get(name)
    return Track(id=ROLE_OF_ENTITY.get(name, name), length_m=box.length if box else 4.5,
                 width_m=box.width if box else 1.8, vehicle_type="car", t=times,
                 x=xy[:, 0], y=xy[:, 1], heading=np.asarray(playback.tracks[name]["h"]),
                 speed=np.asarray(playback.tracks[name]["speed"], dtype=float),
                 s=start + own, lane=np.array([str(int(k)) for k in lanes], dtype=object),
                 lane_index=np.abs(lanes),
                 lateral=-(np.abs(lanes) - 1) * LANE_WIDTH_M + np.sign(lanes) * -offsets)


def _along(path: Floats, point: Floats) -> float:
    """The signed distance along ``path`` (from its start) of ``point``'s projection; before
    the start, negative."""
    lengths = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    k = int(np.argmin(np.hypot(*(path - point).T)))
    k = min(k, len(path) - 2)
    segment = path[k + 1] - path[k]
    norm = math.hypot(*segment)
    if norm == 0:
        return float(lengths[k])
    share = float(np.dot(point - path[k], segment) / norm)
    return float(lengths[k] + share)

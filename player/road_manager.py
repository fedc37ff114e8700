"""esmini's RoadManager (``libesminiRMLib.so``) asked where points lie on an OpenDRIVE map, in a
child process: esmini aborts the whole process on some maps (``std::terminate`` on a signal past
its road's end), so a map is never loaded in the caller.

:func:`probe_map` loads one map and, per group of points (a lanelet's sampled centre line),
answers for each point where esmini puts it (road, lane, lane offset, s) with a fresh position
object per group, so consecutive points are tracked like a moving car; where it lies when
restricted to an expected road; and the expected lane's centre line (every
:data:`CENTRE_STEP_M` along the whole road, as esmini places lane positions). A map the
library refuses or aborts on comes back as ``loaded=False`` with the reason, never as an
exception of the caller.
"""

from __future__ import annotations

import ctypes
import json
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenweave.player.child import bare_child_command
from scenweave.player.locate import find_esmini

LIBRARY = "libesminiRMLib.so"
#: a group's road when it expects none
NO_ROAD = -1
#: esmini's Lane::LaneType bits of the lanes a car drives on (esminiRMLib.hpp's example)
ANY_DRIVING = 1966594
#: spacing of the lane centre lines sampled for the caller (m)
CENTRE_STEP_M = 0.25
#: how long loading a map and probing its points may take (s)
PROBE_TIMEOUT_S = 120.0


class PositionData(ctypes.Structure):
    """esminiRMLib.hpp's ``RM_PositionData``, field for field."""

    x: float
    y: float
    z: float
    h: float
    p: float
    r: float
    hRelative: float
    roadId: int
    junctionId: int
    laneId: int
    laneOffset: float
    s: float

    _fields_ = [
        ("x", ctypes.c_double), ("y", ctypes.c_double), ("z", ctypes.c_double),
        ("h", ctypes.c_double), ("p", ctypes.c_double), ("r", ctypes.c_double),
        ("hRelative", ctypes.c_double), ("roadId", ctypes.c_uint32),
        ("junctionId", ctypes.c_uint32), ("laneId", ctypes.c_int),
        ("laneOffset", ctypes.c_double), ("s", ctypes.c_double),
    ]


@dataclass(frozen=True)
class PointGroup:
    """Points ``(x, y, heading)`` expected on one road and lane (road ``NO_ROAD``: only
    where esmini puts them is asked)."""

    road_id: int
    lane_id: int
    points: list[tuple[float, float, float]]
    #: points located first and not answered: where a car came from (the position object
    #: then prefers the road it is on, as it does for a moving car)
    lead_in: list[tuple[float, float, float]] = field(default_factory=list)


@dataclass
class ProbedPoint:
    """What esmini says of one point."""

    #: where esmini locates the point: road, lane, lateral offset from that lane's centre
    road_id: int
    lane_id: int
    lane_offset: float
    #: located on the expected road only: lane, offset from its centre, s (zeros where the
    #: group expects no road)
    own_road_lane_id: int
    own_road_offset: float
    own_road_s: float
    #: esmini's Lane::LaneType bits of the lane the point is in (1: none, outside the lanes)
    in_lane_type: int = 1


@dataclass
class MapProbe:
    """A map loaded (or not) and its points probed, group by group."""

    loaded: bool
    problem: str = ""
    groups: list[list[ProbedPoint]] = field(default_factory=list)
    #: per group: its expected lane's centre line, (x, y) pairs
    centres: list[list[tuple[float, float]]] = field(default_factory=list)


def library_path() -> Path:
    """The RoadManager library beside the esmini player that ``find_esmini`` finds."""
    return find_esmini().home / "bin" / LIBRARY


def probe_map(xodr: Path, groups: list[PointGroup], library: Path | None = None,
              timeout_s: float = PROBE_TIMEOUT_S) -> MapProbe:
    """Load ``xodr`` in a child's RoadManager and probe every group's points."""
    library = library or library_path()
    with tempfile.TemporaryDirectory(prefix="scenweave-rm-") as scratch:
        request, reply = Path(scratch) / "request.json", Path(scratch) / "reply.json"
        request.write_text(json.dumps({
            "library": str(library), "xodr": str(Path(xodr).resolve()),
            "log": str(Path(scratch) / "esmini.log"),
            "groups": [[g.road_id, g.lane_id, g.points, g.lead_in] for g in groups]}),
            encoding="utf-8")
        try:
            done = subprocess.run(bare_child_command("road_manager", "child_main", str(request),
                                                     str(reply)),
                                  capture_output=True, timeout=timeout_s, check=False)
        except subprocess.TimeoutExpired:
            return MapProbe(False, f"esmini's RoadManager did not finish within {timeout_s} s")
        if done.returncode != 0 or not reply.is_file():
            return MapProbe(False, _why(done, Path(scratch) / "esmini.log"))
        answer: dict[str, Any] = json.loads(reply.read_text(encoding="utf-8"))
    if not answer["loaded"]:
        return MapProbe(False, str(answer.get("problem", "RM_Init failed")))
    centres = {(road, lane): [(x, y) for x, y in line] for road, lane, line in answer["centres"]}
    return MapProbe(True, "", [[ProbedPoint(*p) for p in g] for g in answer["groups"]],
                    [centres.get((g.road_id, g.lane_id), []) for g in groups])


def _why(done: subprocess.CompletedProcess[bytes], log: Path) -> str:
    """The last line esmini logged (or printed) before the child ended."""
    text = log.read_text(encoding="utf-8", errors="replace") if log.is_file() else ""
    text += done.stdout.decode(errors="replace") + done.stderr.decode(errors="replace")
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    last = next((line for line in reversed(lines) if "rror" in line), lines[-1] if lines else "")
    return f"esmini's RoadManager ended with exit code {done.returncode}: {last}"


# --- the child ----------------------------------------------------------------------------------

def _bind(path: str) -> ctypes.CDLL:
    lib = ctypes.CDLL(path)
    lib.RM_Init.argtypes = [ctypes.c_char_p]
    lib.RM_SetLogFilePath.argtypes = [ctypes.c_char_p]
    lib.RM_SetWorldXYHPosition.argtypes = [ctypes.c_int, ctypes.c_double, ctypes.c_double,
                                           ctypes.c_double]
    lib.RM_SetRoadId.argtypes = [ctypes.c_int, ctypes.c_uint32]
    lib.RM_SetLanePosition.argtypes = [ctypes.c_int, ctypes.c_uint32, ctypes.c_int,
                                       ctypes.c_double, ctypes.c_double, ctypes.c_bool]
    lib.RM_GetPositionData.argtypes = [ctypes.c_int, ctypes.POINTER(PositionData)]
    lib.RM_GetRoadLength.argtypes = [ctypes.c_uint32]
    lib.RM_GetRoadLength.restype = ctypes.c_double
    lib.RM_GetInLaneType.argtypes = [ctypes.c_int]
    return lib


def _probe_group(lib: ctypes.CDLL, road_id: int, lane_id: int, points: list[list[float]],
                 lead_in: list[list[float]]) -> list[list[float]]:
    located, restricted = lib.RM_CreatePosition(), lib.RM_CreatePosition()
    data = PositionData()
    for x, y, h in lead_in:
        lib.RM_SetWorldXYHPosition(located, x, y, h)
    out = []
    for x, y, h in points:
        lib.RM_SetWorldXYHPosition(located, x, y, h)
        lib.RM_GetPositionData(located, ctypes.byref(data))
        found = [int(data.roadId), int(data.laneId), float(data.laneOffset)]
        lane_type = int(lib.RM_GetInLaneType(located))
        if road_id == NO_ROAD:
            out.append([*found, 0, 0.0, 0.0, lane_type])
            continue
        lib.RM_SetWorldXYHPosition(restricted, x, y, h)
        lib.RM_SetRoadId(restricted, road_id)
        lib.RM_GetPositionData(restricted, ctypes.byref(data))
        out.append([*found, int(data.laneId), float(data.laneOffset), float(data.s), lane_type])
    for handle in (located, restricted):
        lib.RM_DeletePosition(handle)
    return out


def _centre_line(lib: ctypes.CDLL, road_id: int, lane_id: int) -> list[list[float]]:
    """The lane's centre every CENTRE_STEP_M along its road, as esmini places it."""
    length = float(lib.RM_GetRoadLength(road_id))
    count = max(2, int(length / CENTRE_STEP_M) + 2)
    handle, data = lib.RM_CreatePosition(), PositionData()
    line = []
    for k in range(count):
        s = min(k * length / (count - 1), length)
        if lib.RM_SetLanePosition(handle, road_id, lane_id, 0.0, s, False) >= 0:
            lib.RM_GetPositionData(handle, ctypes.byref(data))
            line.append([float(data.x), float(data.y)])
    lib.RM_DeletePosition(handle)
    return line


def child_main(request_path: str, reply_path: str) -> None:
    """The child's work: load the map, probe every group, write the reply as JSON."""
    request = json.loads(Path(request_path).read_text(encoding="utf-8"))
    lib = _bind(request["library"])
    lib.RM_SetLogFilePath(request["log"].encode())
    if lib.RM_Init(request["xodr"].encode()) != 0:
        reply: dict[str, Any] = {"loaded": False, "problem": "RM_Init refused the map"}
    else:
        lanes = sorted({(road, lane) for road, lane, _, _ in request["groups"]
                        if road != NO_ROAD})
        reply = {"loaded": True,
                 "groups": [_probe_group(lib, road, lane, points, lead_in)
                            for road, lane, points, lead_in in request["groups"]],
                 "centres": [[road, lane, _centre_line(lib, road, lane)]
                             for road, lane in lanes]}
        lib.RM_Close()
    Path(reply_path).write_text(json.dumps(reply), encoding="utf-8")

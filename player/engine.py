"""Playing one prepared scenario in esmini's library, in a child process with a time limit.

esmini keeps global state and aborts the process on some errors (``LOG_ERROR_AND_QUIT``), so a
scenario is never played in the caller's process: ``play_file`` starts a child (forked from a
small server process that has already loaded the library), which steps the scenario at a fixed
time step and sends back every entity's state at each step, the collisions esmini detected and
the storyboard's state changes. A crash, an abort or a hang of the engine becomes a
``Playback`` with ``engine_error`` set, never an exception of the caller.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from player.locate import find_esmini
from player.playback import Playback, StoryboardChange

#: esmini's StoryBoardElement::ElementType and ::State (esminiLib.hpp's public enum values)
ELEMENT_TYPES = {1: "storyboard", 2: "story", 3: "act", 4: "maneuver_group", 5: "maneuver",
                 6: "event", 7: "action"}
ELEMENT_STATES = {0: "init", 1: "standby", 2: "running", 3: "complete"}
#: how many log lines of esmini a playback keeps (warnings and errors first)
LOG_LINES_KEPT = 40


class ObjectState(ctypes.Structure):
    """esminiLib.hpp's ``SE_ScenarioObjectState``, field for field."""

    _fields_ = [
        ("id", ctypes.c_int), ("model_id", ctypes.c_int), ("ctrl_type", ctypes.c_int),
        ("timestamp", ctypes.c_double),
        ("x", ctypes.c_double), ("y", ctypes.c_double), ("z", ctypes.c_double),
        ("h", ctypes.c_double), ("p", ctypes.c_double), ("r", ctypes.c_double),
        ("roadId", ctypes.c_uint32), ("junctionId", ctypes.c_uint32), ("t", ctypes.c_double),
        ("laneId", ctypes.c_int), ("laneOffset", ctypes.c_double), ("s", ctypes.c_double),
        ("speed", ctypes.c_double),
        ("centerOffsetX", ctypes.c_double), ("centerOffsetY", ctypes.c_double),
        ("centerOffsetZ", ctypes.c_double),
        ("width", ctypes.c_double), ("length", ctypes.c_double), ("height", ctypes.c_double),
        ("objectType", ctypes.c_int), ("objectCategory", ctypes.c_int),
        ("wheel_angle", ctypes.c_double), ("wheel_rot", ctypes.c_double),
        ("visibilityMask", ctypes.c_int),
    ]


STATE_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_char_p, ctypes.c_int, ctypes.c_int,
                                  ctypes.c_char_p)
_library: Any = None


def _load(library_path: str) -> Any:
    global _library
    if _library is None:
        lib = ctypes.CDLL(library_path)
        lib.SE_InitWithArgs.argtypes = [ctypes.c_int, ctypes.POINTER(ctypes.c_char_p)]
        lib.SE_StepDT.argtypes = [ctypes.c_double]
        lib.SE_GetSimulationTime.restype = ctypes.c_double
        lib.SE_GetObjectState.argtypes = [ctypes.c_int, ctypes.POINTER(ObjectState)]
        lib.SE_GetObjectName.restype = ctypes.c_char_p
        lib.SE_CollisionDetection.argtypes = [ctypes.c_bool]
        lib.SE_RegisterStoryBoardElementStateChangeCallback.argtypes = [STATE_CALLBACK]
        _library = lib
    return _library


def preload() -> None:
    """Load the library in the fork server, so that each child starts with it loaded."""
    _load(str(find_esmini().library))


def _step_scenario(library_path: str, xosc_path: str, time_step_s: float, until_s: float,
                   log_path: str) -> dict:
    """The child's work: init, step to ``until_s`` (or esmini's quit), record everything."""
    lib = _load(library_path)
    changes: list[StoryboardChange] = []

    def on_change(name: bytes, kind: int, state: int, full_path: bytes) -> None:
        changes.append(StoryboardChange(round(lib.SE_GetSimulationTime(), 4),
                                        name.decode(errors="replace"),
                                        ELEMENT_TYPES.get(kind, str(kind)),
                                        ELEMENT_STATES.get(state, str(state))))

    args = [b"esmini", b"--osc", xosc_path.encode(), b"--headless", b"--fixed_timestep",
            str(time_step_s).encode(), b"--collision", b"--disable_stdout",
            b"--logfile_path", log_path.encode()]
    argv = (ctypes.c_char_p * len(args))(*args)
    started = time.perf_counter()
    if lib.SE_InitWithArgs(len(args), argv) != 0:
        return {"engine_error": "esmini could not load the scenario (SE_InitWithArgs failed)",
                "storyboard": [c.to_list() for c in changes]}
    loaded = time.perf_counter()
    # SE_InitWithArgs clears the callbacks, so it is registered after (the storyboard only
    # starts in the first step)
    callback = STATE_CALLBACK(on_change)
    lib.SE_RegisterStoryBoardElementStateChangeCallback(callback)
    ids = [lib.SE_GetId(i) for i in range(lib.SE_GetNumberOfObjects())]
    names = {i: lib.SE_GetObjectName(i).decode() for i in ids}
    playback = Playback.empty(names.values())
    state = ObjectState()

    def record() -> None:
        playback.times.append(round(lib.SE_GetSimulationTime(), 4))
        for object_id, name in names.items():
            lib.SE_GetObjectState(object_id, ctypes.byref(state))
            playback.add_state(name, state)
            for k in range(lib.SE_GetObjectNumberOfCollisions(object_id)):
                other = names.get(lib.SE_GetObjectCollision(object_id, k))
                if other is not None:
                    playback.add_collision(playback.times[-1], name, other)

    record()
    while lib.SE_GetQuitFlag() == 0 and lib.SE_GetSimulationTime() < until_s - 1e-9:
        lib.SE_StepDT(time_step_s)
        record()
    quit_flag = lib.SE_GetQuitFlag()
    lib.SE_Close()
    playback.storyboard = changes
    playback.quit_by_engine = bool(quit_flag) and playback.times[-1] < until_s - time_step_s
    playback.timings_s = {"load": round(loaded - started, 4),
                          "step": round(time.perf_counter() - loaded, 4)}
    return playback.to_dict()


def _child(conn: Any, *args: Any) -> None:
    _silence_stdio()  # esmini prints its version and config lines even with --disable_stdout
    try:
        conn.send(_step_scenario(*args))
    except Exception as err:  # noqa: BLE001 - reported to the parent as the engine's error
        conn.send({"engine_error": f"{type(err).__name__}: {err}"})
    finally:
        conn.close()


def _silence_stdio() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    os.close(devnull)


_context: Any = None


def _process_context() -> Any:
    """A forkserver context whose server has the library loaded (children start in ms)."""
    global _context
    if _context is None:
        _context = multiprocessing.get_context("forkserver")
        _context.set_forkserver_preload(["player.preloaded"])
    return _context


def play_file(xosc_path: Path, until_s: float, time_step_s: float = 0.05,
              wall_time_s: float = 30.0) -> Playback:
    """Play a prepared (esmini-ready) scenario file headless; never raises for the scenario.

    The child is killed after ``wall_time_s``; what esmini logged is kept in the playback.
    """
    library = str(find_esmini().library)
    context = _process_context()
    with tempfile.TemporaryDirectory(prefix="scenweave-esmini-") as tmp:
        log_path = os.path.join(tmp, "esmini.log")
        receiver, sender = context.Pipe(duplex=False)
        child = context.Process(target=_child, daemon=True,
                                args=(sender, library, str(xosc_path), time_step_s, until_s,
                                      log_path))
        started = time.perf_counter()
        child.start()
        sender.close()
        reply = _receive(receiver, wall_time_s)
        child.join(timeout=0 if reply is None else 5)
        if child.is_alive():
            child.kill()
            child.join()
        log = _log_lines(log_path)
    if reply is None:
        why = (f"esmini did not finish within {wall_time_s:g} s (ReplaySettings.wall_time_s)"
               if child.exitcode in (None, -9) else
               f"esmini ended the process (exit code {child.exitcode})")
        reply = {"engine_error": why}
    playback = Playback.from_dict(reply)
    playback.log = log
    playback.timings_s["total"] = round(time.perf_counter() - started, 4)
    return playback


def _receive(receiver: Any, wall_time_s: float) -> dict | None:
    try:
        if receiver.poll(wall_time_s):
            return receiver.recv()
    except (EOFError, OSError):
        pass
    return None


def _log_lines(path: str) -> list[str]:
    try:
        lines = Path(path).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []
    important = [line for line in lines if "warn" in line.lower() or "error" in line.lower()]
    return (important or lines)[-LOG_LINES_KEPT:]

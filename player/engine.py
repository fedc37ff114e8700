"""Playing one prepared scenario in esmini's library, in a child process with a time limit.

esmini keeps global state and aborts the process on some errors (``LOG_ERROR_AND_QUIT``), so a
scenario is never played in the caller's process. A small *player server* (one per caller
process, started on first use: a fresh interpreter that imports the player and loads the
library once) forks one child per scenario; the child steps the scenario at a fixed time step
and sends back every entity's state at each step, the collisions esmini detected and the
storyboard's state changes. The server kills a child still running after the wall-clock limit.
A crash, an abort or a hang of the engine becomes a ``Playback`` with ``engine_error`` set,
never an exception of the caller.

Why not ``multiprocessing``: a forkserver (or spawn) child re-imports the caller's
``__main__`` module, and everything it imports, for every scenario (40 ms for the CLI, 0.4 s
for a script importing numpy and scipy), and forking the caller itself is unsafe once it runs
threads (the agent's LLM). The server is a fork of a process that holds nothing but the player.
"""

from __future__ import annotations

import atexit
import ctypes
import itertools
import os
import pickle
import resource
import select
import signal
import struct
import subprocess
import threading
import time
from pathlib import Path
from typing import IO, Any, TypedDict

from scenweave.player.child import bare_child_command
from scenweave.player.locate import find_esmini
from scenweave.player.playback import Playback, StoryboardChange
from scenweave.player.recorder import INITIAL_STEPS, MAX_INITIAL_STEPS, StateRecorder
from scenweave.player.scratch import scratch_folder

#: esmini's StoryBoardElement::ElementType and ::State (esminiLib.hpp's public enum values)
ELEMENT_TYPES = {1: "storyboard", 2: "story", 3: "act", 4: "maneuver_group", 5: "maneuver",
                 6: "event", 7: "action"}
ELEMENT_STATES = {0: "init", 1: "standby", 2: "running", 3: "complete"}
#: how many log lines of esmini a playback keeps (warnings and errors first)
LOG_LINES_KEPT = 40
#: how a playback's ``engine_error`` begins when the wall-clock limit stopped it
TIMEOUT_MESSAGE = "esmini did not finish within"
#: how long past the wall-clock limit the caller waits for the server's answer (s)
SERVER_GRACE_S = 20.0
#: how long the server may take to start (import the engine, load the library) (s)
SERVER_START_S = 60.0


class ObjectState(ctypes.Structure):
    """esminiLib.hpp's ``SE_ScenarioObjectState``, field for field (the annotations tell the
    type checker what ``_fields_`` makes at run time)."""

    id: int
    model_id: int
    ctrl_type: int
    timestamp: float
    x: float
    y: float
    z: float
    h: float
    p: float
    r: float
    roadId: int
    junctionId: int
    t: float
    laneId: int
    laneOffset: float
    s: float
    speed: float
    centerOffsetX: float
    centerOffsetY: float
    centerOffsetZ: float
    width: float
    length: float
    height: float
    objectType: int
    objectCategory: int
    wheel_angle: float
    wheel_rot: float
    visibilityMask: int

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
_library: ctypes.CDLL | None = None


class _Request(TypedDict):
    """What the caller asks the server: play one scenario (paths as strings)."""

    library: str
    xosc: str
    time_step_s: float
    until_s: float
    log: str
    wall_time_s: float


class _Answer(TypedDict, total=False):
    """The server's answer to a ``_Request``: the child's reply (a ``Playback.to_dict`` with
    the child's ``marks``, or ``engine_error``), or why there is none."""

    reply_bytes: bytes | None
    exitcode: int
    timed_out: bool
    server_error: str


def _load(library_path: str) -> ctypes.CDLL:
    global _library
    if _library is None:
        lib = ctypes.CDLL(library_path)
        lib.SE_InitWithArgs.argtypes = [ctypes.c_int, ctypes.POINTER(ctypes.c_char_p)]
        lib.SE_StepDT.argtypes = [ctypes.c_double]
        lib.SE_GetSimulationTime.restype = ctypes.c_double
        # the state's address: the recorder fills the slots of one array (player.recorder)
        lib.SE_GetObjectState.argtypes = [ctypes.c_int, ctypes.c_void_p]
        lib.SE_GetObjectName.restype = ctypes.c_char_p
        lib.SE_CollisionDetection.argtypes = [ctypes.c_bool]
        lib.SE_RegisterStoryBoardElementStateChangeCallback.argtypes = [STATE_CALLBACK]
        _library = lib
    return _library


def preload() -> None:
    """Load the library in this process (the server), so that each child starts with it."""
    _load(str(find_esmini().library))


# --- the child: one scenario ------------------------------------------------------------------
def _step_scenario(library_path: str, xosc_path: str, time_step_s: float, until_s: float,
                   log_path: str) -> dict[str, Any]:
    """The child's work: init, step to ``until_s`` (or esmini's quit), record everything."""
    lib = _load(library_path)
    changes: list[StoryboardChange] = []

    def on_change(name: bytes, kind: int, state: int, full_path: bytes) -> None:
        changes.append(StoryboardChange(round(lib.SE_GetSimulationTime(), 4),
                                        name.decode(errors="replace"),
                                        ELEMENT_TYPES.get(kind, str(kind)),
                                        ELEMENT_STATES.get(state, str(state))))

    # --traj_filter 0: esmini merges trajectory vertices closer than 0.1 m by default, which
    # turns a recorded creep into jumps of 0.1 m and more (in-situ scenarios play every vertex)
    args = [b"esmini", b"--osc", xosc_path.encode(), b"--headless", b"--fixed_timestep",
            str(time_step_s).encode(), b"--collision", b"--disable_stdout",
            b"--traj_filter", b"0", b"--logfile_path", log_path.encode()]
    argv = (ctypes.c_char_p * len(args))(*args)
    started = time.perf_counter()
    if lib.SE_InitWithArgs(len(args), argv) != 0:
        return {"engine_error": "esmini could not load the scenario (SE_InitWithArgs failed)",
                "storyboard": [c.to_list() for c in changes],
                "marks": {"started": started, "loaded": time.perf_counter()}}
    loaded = time.perf_counter()
    # SE_InitWithArgs clears the callbacks, so it is registered after (the storyboard only
    # starts in the first step)
    callback = STATE_CALLBACK(on_change)
    lib.SE_RegisterStoryBoardElementStateChangeCallback(callback)
    ids = [lib.SE_GetId(i) for i in range(lib.SE_GetNumberOfObjects())]
    names = {i: lib.SE_GetObjectName(i).decode() for i in ids}
    steps = min(int(until_s / time_step_s) + 2, MAX_INITIAL_STEPS) if until_s > 0 else INITIAL_STEPS
    recorder = StateRecorder(lib, ObjectState, ids, names, steps)
    recorder.record()
    while lib.SE_GetQuitFlag() == 0 and lib.SE_GetSimulationTime() < until_s - 1e-9:
        lib.SE_StepDT(time_step_s)
        recorder.record()
    stepped = time.perf_counter()
    quit_flag = lib.SE_GetQuitFlag()
    lib.SE_Close()  # flushes esmini's log, which the caller reads
    closed = time.perf_counter()
    playback = recorder.playback()
    playback.storyboard = changes
    playback.quit_by_engine = bool(quit_flag) and playback.times[-1] < until_s - time_step_s
    playback.timings_s = {"load": round(loaded - started, 4),
                          "step": round(stepped - loaded, 4)}
    reply = playback.to_dict()
    reply["marks"] = {"started": started, "loaded": loaded, "stepped": stepped,
                      "closed": closed}
    return reply


def _silence_stdio() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    os.close(devnull)


# --- the server: forks a child per scenario, enforces the wall-clock limit -------------------
def serve() -> None:
    """The player server's loop: one request (a pickled dict) in on stdin, one reply out on
    the original stdout, until stdin closes (``bare_child_command("engine", "serve")`` runs
    it); esmini's own output goes to /dev/null.

    A child is forked ahead, before its request arrives (``_Standby``): the fork and the
    child's setup happen while the caller makes the next scenario, not while it waits."""
    requests = os.fdopen(os.dup(0), "rb", buffering=0)
    replies = os.fdopen(os.dup(1), "wb", buffering=0)
    devnull = os.open(os.devnull, os.O_RDWR)
    os.dup2(devnull, 0)
    os.dup2(devnull, 1)
    os.close(devnull)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the caller's Ctrl-C is the caller's
    try:
        preload()
    except Exception as err:  # noqa: BLE001 - answered to every request instead
        broken = f"{type(err).__name__}: {err}"
    else:
        broken = ""
    _write_frame(replies, {"ready": not broken, "problem": broken})
    private = (requests.fileno(), replies.fileno())
    standby = None if broken else _Standby.fork(private)
    while (request := _read_frame(requests)) is not None:
        if standby is None:
            _write_frame(replies, {"server_error": broken})
            continue
        answer = standby.play(request)
        _write_frame(replies, answer)
        standby.reap()
        standby = _Standby.fork(private)  # the next one, while the caller reads the answer
    if standby is not None:
        standby.dismiss()


class _Standby:
    """A child forked ahead of its scenario, waiting for its request on a pipe of its own.

    It plays one scenario and exits: every scenario still gets a fresh process (esmini's
    global state, a crash or an abort stay with it). It exits on its own when the server
    goes (its request pipe closes), so it never outlives the server.
    """

    def __init__(self, pid: int, orders: int, results: int) -> None:
        self.pid, self.orders, self.results = pid, orders, results

    @classmethod
    def fork(cls, private: tuple[int, ...]) -> _Standby:
        """Fork the child; ``private`` are the server's descriptors it must not hold."""
        order_r, order_w = os.pipe()
        result_r, result_w = os.pipe()
        pid = os.fork()
        if pid == 0:
            for fd in (order_w, result_r, *private):
                os.close(fd)
            _standby_child(order_r, result_w)  # never returns
        os.close(order_r)
        os.close(result_w)
        return cls(pid, order_w, result_r)

    def play(self, request: _Request) -> _Answer:
        """Hand the child ``request``; its pickled reply, or why there is none (killed at
        the wall-clock limit)."""
        asked = time.perf_counter()
        try:
            with os.fdopen(self.orders, "wb") as orders:
                orders.write(pickle.dumps({**request, "asked": asked}, pickle.HIGHEST_PROTOCOL))
        except BrokenPipeError:  # it died waiting (killed from outside): its exit code says
            pass
        chunks, timed_out = _read_until(self.results, self.pid,
                                        asked + request["wall_time_s"])
        if chunks and not timed_out:
            # a whole reply is written before the child exits; the exit (freeing esmini's
            # road network) is waited for after the caller has its answer (``reap``)
            return {"reply_bytes": b"".join(chunks)}
        return {"reply_bytes": None, "exitcode": self.reap(), "timed_out": timed_out}

    def reap(self) -> int:
        """Wait for the child to end; its exit code (negative: the signal that ended it)."""
        if self.pid == 0:
            return 0
        _, status = os.waitpid(self.pid, 0)
        self.pid = 0
        return os.waitstatus_to_exitcode(status)

    def dismiss(self) -> None:
        """End the waiting child (it reads the end of its request pipe and exits)."""
        os.close(self.orders)
        os.close(self.results)
        self.reap()


def _read_until(fd: int, pid: int, deadline: float) -> tuple[list[bytes], bool]:
    """Everything ``fd`` gives until it closes; killing ``pid`` at ``deadline`` (then
    ``True``)."""
    chunks: list[bytes] = []
    with os.fdopen(fd, "rb", buffering=0) as pipe:
        while True:
            remaining = deadline - time.perf_counter()
            if remaining <= 0:
                os.kill(pid, signal.SIGKILL)
                return chunks, True
            if not select.select([pipe], [], [], remaining)[0]:
                continue
            chunk = pipe.read(1 << 20)
            if not chunk:
                return chunks, False
            chunks.append(chunk)


def _standby_child(orders: int, results: int) -> None:
    """The forked child: wait for the request, play it, send the pickled reply, exit."""
    code = 0
    try:
        _silence_stdio()
        with os.fdopen(orders, "rb") as pipe:
            data = pipe.read()
        if not data:  # the server went, or dismissed this child
            os._exit(0)
        request = pickle.loads(data)
        reply: dict[str, Any]
        try:
            reply = _step_scenario(request["library"], request["xosc"],
                                   request["time_step_s"], request["until_s"], request["log"])
        except Exception as err:  # noqa: BLE001 - reported as the engine's error
            reply = {"engine_error": f"{type(err).__name__}: {err}"}
        marks = reply.setdefault("marks", {})
        marks["asked"] = request["asked"]
        marks["peak_rss_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        marks["packed"] = time.perf_counter()
        with os.fdopen(results, "wb") as out:
            out.write(pickle.dumps(reply, pickle.HIGHEST_PROTOCOL))
    except BaseException:  # noqa: BLE001 - the exit code says it
        code = 70
    finally:
        os._exit(code)


def _write_frame(stream: IO[bytes], obj: object) -> None:
    data = pickle.dumps(obj, pickle.HIGHEST_PROTOCOL)
    view = memoryview(struct.pack("<Q", len(data)) + data)
    while view:  # an unbuffered stream may take part of it
        view = view[stream.write(view) or 0:]


def _read_frame(stream: IO[bytes]) -> Any:
    header = _read_exact(stream, 8)
    if header is None:
        return None
    data = _read_exact(stream, struct.unpack("<Q", header)[0])
    return None if data is None else pickle.loads(data)


def _read_exact(stream: IO[bytes], size: int) -> bytes | None:
    parts: list[bytes] = []
    left = size
    while left:
        chunk = stream.read(left)
        if not chunk:
            return None
        parts.append(chunk)
        left -= len(chunk)
    return b"".join(parts)


class _Server:
    """The caller's handle on its player server (started on first use, again after a crash;
    a fork of the caller starts its own)."""

    def __init__(self) -> None:
        self.forget()

    def forget(self) -> None:
        """Drop the handle without touching the server (in a forked child of the caller)."""
        self.process: subprocess.Popen[bytes] | None = None
        self.ready = False
        self.lock = threading.Lock()
        self.stderr: Path | None = None

    def launch(self) -> subprocess.Popen[bytes]:
        """Start the server if there is none, without waiting for it; its process."""
        if self.process is not None and self.process.poll() is None:
            return self.process
        self.process, self.ready = None, False
        self.stderr = scratch_folder("esmini") / f"server-{os.getpid()}.log"
        with open(self.stderr, "wb") as errors:
            self.process = subprocess.Popen(
                bare_child_command("engine", "serve"),
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=errors, bufsize=0,
                close_fds=True, start_new_session=True)
        return self.process

    def ask(self, request: _Request, timeout_s: float) -> _Answer:
        """Send ``request``; the server's reply, or ``{"server_error": why}``."""
        with self.lock:
            process, problem = self._start()
            if process is None:
                return {"server_error": problem}
            reply: _Answer | None
            try:
                to_server, from_server = _pipes(process)
                _write_frame(to_server, request)
                if not select.select([from_server], [], [], timeout_s)[0]:
                    self.stop()
                    return {"server_error": f"the player server did not answer in {timeout_s:g} s"}
                reply = _read_frame(from_server)
            except (OSError, EOFError, pickle.UnpicklingError) as err:
                reply, problem = None, f"{type(err).__name__}: {err}"
            if reply is None:
                why = problem or self._last_words()
                self.stop()
                return {"server_error": f"the player server ended ({why})"}
            return reply

    def _start(self) -> tuple[subprocess.Popen[bytes] | None, str]:
        """Launch the server if needed and wait until it has loaded the library: its process,
        or ``None`` and why it did not start."""
        process = self.launch()
        if self.ready:
            return process, ""
        hello: dict[str, Any] | None
        try:
            _, from_server = _pipes(process)
            if not select.select([from_server], [], [], SERVER_START_S)[0]:
                raise TimeoutError(f"no answer in {SERVER_START_S:g} s")
            hello = _read_frame(from_server)
        except (OSError, EOFError, TimeoutError, pickle.UnpicklingError) as err:
            hello = {"ready": False, "problem": f"{type(err).__name__}: {err}"}
        if not hello or not hello.get("ready"):
            problem = (hello or {}).get("problem") or self._last_words()
            self.stop()
            return None, f"the player server did not start ({problem})"
        self.ready = True
        return process, ""

    def _last_words(self) -> str:
        if self.stderr is None:
            return "no message"
        try:
            lines = self.stderr.read_text(errors="replace").strip().splitlines()
        except OSError:
            lines = []
        return lines[-1] if lines else "no message"

    def stop(self) -> None:
        process, self.process, self.ready = self.process, None, False
        if process is None:
            return
        try:
            if process.stdin is not None:
                process.stdin.close()
            process.wait(timeout=2)
        except (OSError, subprocess.TimeoutExpired):
            process.kill()
            process.wait()
        finally:
            if process.stdout is not None:
                process.stdout.close()


def _pipes(process: subprocess.Popen[bytes]) -> tuple[IO[bytes], IO[bytes]]:
    """The server's stdin and stdout (``_Server.launch`` opens both as pipes)."""
    if process.stdin is None or process.stdout is None:
        raise OSError("the player server's stdin or stdout is not a pipe")
    return process.stdin, process.stdout


_server = _Server()
atexit.register(_server.stop)
os.register_at_fork(after_in_child=_server.forget)
_counter = itertools.count()


def warm_up() -> None:
    """Start the player server now (it loads while the caller prepares the scenario)."""
    with _server.lock:
        _server.launch()


def play_xml(xosc: bytes, until_s: float, time_step_s: float = 0.05,
             wall_time_s: float = 30.0) -> Playback:
    """Play a prepared (esmini-ready) scenario given as XML; never raises for the scenario.

    The child is killed after ``wall_time_s``; what esmini logged is kept in the playback.
    """
    name = f"{os.getpid()}-{next(_counter)}"
    path = scratch_folder("esmini") / f"{name}.xosc"
    path.write_bytes(xosc)
    try:
        return play_file(path, until_s, time_step_s, wall_time_s)
    finally:
        path.unlink(missing_ok=True)


def play_file(xosc_path: Path, until_s: float, time_step_s: float = 0.05,
              wall_time_s: float = 30.0) -> Playback:
    """Play a prepared (esmini-ready) scenario file headless; never raises for the scenario.

    The child is killed after ``wall_time_s``; what esmini logged is kept in the playback.
    ``timings_s``: ``start`` (until the child runs), ``load``, ``step``, ``collect`` (the
    playback back here: ``close``, ``pack``, ``transfer``), ``total``.
    """
    library = str(find_esmini().library)
    log_path = scratch_folder("esmini") / f"{os.getpid()}-{next(_counter)}.log"
    started = time.perf_counter()
    answer = _server.ask({"library": library, "xosc": str(Path(xosc_path).resolve()),
                          "time_step_s": time_step_s, "until_s": until_s,
                          "log": str(log_path), "wall_time_s": wall_time_s},
                         wall_time_s + SERVER_GRACE_S)
    reply = _unpickled(answer.get("reply_bytes"))
    log = _log_lines(log_path)
    log_path.unlink(missing_ok=True)
    if reply is None:
        if answer.get("server_error"):
            why = answer["server_error"]
        elif answer.get("timed_out"):
            why = f"{TIMEOUT_MESSAGE} {wall_time_s:g} s (ReplaySettings.wall_time_s)"
        elif answer.get("reply_bytes"):
            why = "the player's child sent a torn reply"
        else:
            why = _ended_why(answer.get("exitcode"))
        reply = {"engine_error": why}
    marks = reply.pop("marks", {})
    playback = Playback.from_dict(reply)
    playback.log = log
    done = time.perf_counter()
    playback.timings_s.update(_split(marks, started, done))
    return playback


def _unpickled(data: bytes | None) -> dict[str, Any] | None:
    """The child's reply, or ``None`` for none or a torn one."""
    if not data:
        return None
    try:
        reply = pickle.loads(data)
    except Exception:  # noqa: BLE001 - a torn reply is no reply
        return None
    return reply if isinstance(reply, dict) else None


def _split(marks: dict[str, float], started: float, done: float) -> dict[str, float]:
    """Where a replay's time went outside esmini's ``load`` and ``step`` (the child's clock
    marks are this machine's monotonic clock): ``start`` (request to the child running),
    ``close`` (esmini's ``SE_Close``), ``pack`` (the tracks cut out of the recorded states and
    pickled), ``transfer`` (the reply back here), ``collect`` (all three), ``total``; and
    ``child_peak_rss_mb``, the peak memory of the child that played."""
    split = {"total": round(done - started, 4)}
    if "peak_rss_kb" in marks:  # the child's peak memory: esmini with the map loaded
        split["child_peak_rss_mb"] = round(marks["peak_rss_kb"] / 1024, 1)
    if "started" in marks:
        split["start"] = round(marks["started"] - started, 4)
    if "stepped" in marks:
        split["collect"] = round(done - marks["stepped"], 4)
    if {"stepped", "closed", "packed"} <= marks.keys():
        split["close"] = round(marks["closed"] - marks["stepped"], 4)
        split["pack"] = round(marks["packed"] - marks["closed"], 4)
        split["transfer"] = round(done - marks["packed"], 4)
    return split


def _ended_why(exitcode: int | None) -> str:
    """How the child playing a scenario ended without a reply: killed by a signal (a crash of
    esmini, SIGSEGV or SIGABRT, or a kill from outside) or an exit code of its own."""
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"esmini crashed ({name}, exit code {exitcode})"
    return f"esmini ended the process (exit code {exitcode})"


def _log_lines(path: Path) -> list[str]:
    try:
        lines = Path(path).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []
    important = [line for line in lines if "warn" in line.lower() or "error" in line.lower()]
    return (important or lines)[-LOG_LINES_KEPT:]

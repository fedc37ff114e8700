"""Host-side evidence for the attack tests: listeners, processes, canaries, and a look inside
a sandbox held open at the end of its script."""

from __future__ import annotations

import contextlib
import os
import select
import signal
import socket
import stat
import time
import uuid
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TypeVar

from scenweave.sandbox import ExecResult

T = TypeVar("T")


def marker() -> str:
    """A unique string an attack puts into the processes it leaves behind."""
    return f"scenweave-attack-{uuid.uuid4().hex}"


def processes_with(text: str) -> list[int]:
    """Host pids whose command line contains ``text``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if text.encode() in cmdline and int(entry.name) != os.getpid():
            found.append(int(entry.name))
    return found


class Listener:
    """A TCP and a UDP socket on every host address (loopback included) that record arrivals."""

    def __init__(self, udp_port: int = 0) -> None:
        self.tcp = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.tcp.bind(("0.0.0.0", 0))
        self.tcp.listen(8)
        self.tcp.setblocking(False)
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("0.0.0.0", udp_port))
        self.udp.setblocking(False)

    @property
    def tcp_port(self) -> int:
        return self.tcp.getsockname()[1]

    @property
    def udp_port(self) -> int:
        return self.udp.getsockname()[1]

    def received(self, wait_s: float = 0.5) -> list[str]:
        """Everything that reached the listener: connections and datagrams."""
        events = []
        readable, _, _ = select.select([self.tcp, self.udp], [], [], wait_s)
        if self.tcp in readable:
            connection, peer = self.tcp.accept()
            events.append(f"tcp connection from {peer}")
            connection.close()
        if self.udp in readable:
            data, peer = self.udp.recvfrom(65536)
            events.append(f"udp {data[:40]!r} from {peer}")
        return events

    def close(self) -> None:
        self.tcp.close()
        self.udp.close()


#: scripts that end with ``hold(tag)`` keep their sandbox standing (as ``<tag> 30``, a sleep)
#: so the host can look inside through ``/proc/<pid>/root`` before it is torn down
HOLD = """
import os
def hold(tag):
    os.execv("/bin/sleep", [tag, "30"])  # the tag as argv[0]: sleep takes no extra operand
"""


def held_run(box, code: str, params: dict, out_dir: Path,
             look: Callable[[int], T]) -> tuple[ExecResult, T]:
    """Run ``HOLD + code`` (which ends with ``hold(params["tag"])``), call ``look`` with the
    host pid of the held sandbox, then kill it; return the run's result and what was seen."""
    with ThreadPoolExecutor(max_workers=1) as pool:
        running = pool.submit(box.run, HOLD + code, params, out_dir)
        try:
            seen = look(wait_for_processes(params["tag"], running)[0])
        finally:
            for pid in processes_with(params["tag"]):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
        return running.result(), seen


def run_seeing_processes(box, code: str, params: dict, out_dir: Path,
                         count: int) -> ExecResult:
    """Run ``code`` and return its result, once the host has seen ``count`` processes tagged
    ``params["tag"]`` alive during the run (AssertionError if it never did)."""
    with ThreadPoolExecutor(max_workers=1) as pool:
        running = pool.submit(box.run, code, params, out_dir)
        wait_for_processes(params["tag"], running, count)
        return running.result()


def wait_for_processes(tag: str, running: Future, count: int = 1) -> list[int]:
    """The host pids of ``count`` processes tagged ``tag`` once the sandbox run in ``running``
    has started them; AssertionError with the run's result if it ends first."""
    while not running.done():
        if len(found := processes_with(tag)) >= count:
            return found
        time.sleep(0.02)
    raise AssertionError(f"the script never started {count} processes tagged {tag}: "
                         f"{running.result()}")


def cpu_seconds(pids: list[int]) -> float:
    """User plus system CPU time the kernel accounted to ``pids`` (gone ones count 0)."""
    ticks = 0
    for pid in pids:
        fields = _stat(pid)
        ticks += int(fields[11]) + int(fields[12]) if fields else 0  # utime, stime (14, 15)
    return ticks / os.sysconf("SC_CLK_TCK")


def _stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/<pid>/stat`` after the command (field 3 first), None if gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return None


def bytes_under(folder: Path) -> int:
    """Total size of the regular files under ``folder``, never following links."""
    total = 0
    for parent, _, names in os.walk(folder):
        for name in names:
            info = os.lstat(os.path.join(parent, name))
            total += info.st_size if stat.S_ISREG(info.st_mode) else 0
    return total


def peak_memory_bytes(pid: int) -> int | None:
    """The peak memory use (tmpfs pages included) of the memory cgroup ``pid`` runs in, read
    on the host (cgroup v1 or v2); None when it has no memory cgroup to read."""
    for line in Path(f"/proc/{pid}/cgroup").read_text().splitlines():
        _, controllers, path = line.split(":", 2)
        if controllers == "memory":
            peak = Path("/sys/fs/cgroup/memory", path.lstrip("/"), "memory.max_usage_in_bytes")
        elif controllers == "":
            peak = Path("/sys/fs/cgroup", path.lstrip("/"), "memory.peak")
        else:
            continue
        if peak.exists():
            return int(peak.read_text())
    return None


def file_size(path: Path) -> int | None:
    """Size of the regular file at ``path`` (never following a link), else None."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return None
    return info.st_size if stat.S_ISREG(info.st_mode) else None


def start_time(pid: int) -> int | None:
    """When ``pid`` started (clock ticks after boot), None when there is no such process; a
    zombie still has one."""
    fields = _stat(pid)
    return int(fields[19]) if fields else None  # field 22 of stat


def pids_cgroup(pid: int) -> Path:
    """The folder of the pids cgroup ``pid`` runs in (cgroup v1 or v2)."""
    entries = [line.split(":", 2) for line in Path(f"/proc/{pid}/cgroup").read_text().split("\n")
               if line]
    for _, controllers, path in entries:
        if "pids" in controllers.split(","):
            return Path("/sys/fs/cgroup/pids", path.lstrip("/"))
    return next(Path("/sys/fs/cgroup", path.lstrip("/")) for _, controllers, path in entries
                if controllers == "")


def members(cgroup: Path) -> dict[int, int | None]:
    """The processes in ``cgroup`` now, each with its start time (so a reused pid differs)."""
    pids = map(int, (cgroup / "cgroup.procs").read_text().split())
    return {pid: start_time(pid) for pid in pids}


def survivors(processes: dict[int, int | None]) -> list[int]:
    """The ``processes`` (pid -> start time) that still exist, zombies included."""
    return [pid for pid, start in processes.items()
            if start is not None and start_time(pid) == start]

"""Faults injected into real queue processes, for the fault suite (``tests/faults/``) and
``benchmarks/faults.py``: a real ``redis-server`` killed with SIGKILL and restarted (with its
append-only file or without), real ``scenweave worker`` processes (one killed with SIGKILL
mid-job) and a real ``scenweave submit --wait``. Each fault ends in a ``Delivery``: which of
the run's scenarios reached its run folder once, which never did, which twice, the exit codes
on the way and the seconds from the fault to the finished run.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path

from scenweave.queue.connection import OUTAGE_ENV
from scenweave.schemas.scenario_folder import RUN_FILE, STATUS_NAME, folder_damage
from scenweave.testing.processes import stop_processes
from scenweave.testing.redis_server import RedisServer

CLI = [sys.executable, "-m", "scenweave.cli"]
#: the classes of the sample records a fault run submits (3 rows each with --per-class 3)
CLASSES = ("BRAKE", "LCF", "CINF", "FLF")


@dataclass
class Delivery:
    """What reached the run folder after a fault, and how the commands ended."""

    fault: str
    expected: int
    once: int = 0
    lost: int = 0
    doubled: int = 0
    not_ok: list[str] = field(default_factory=list)
    #: scenario folders not whole: a file their status.json names missing or unreadable
    damaged: list[str] = field(default_factory=list)
    exit_codes: list[int] = field(default_factory=list)
    recover_s: float = 0.0
    output: str = ""

    def line(self) -> str:
        """One line of ``benchmarks/faults.py``."""
        return (f"{self.fault:<40} delivered once {self.once:>2}/{self.expected:<2} lost "
                f"{self.lost}  doubled {self.doubled}  half-written {len(self.damaged)}  "
                f"not ok {len(self.not_ok)}  exit "
                f"{','.join(map(str, self.exit_codes))}  recovered in {self.recover_s:.1f} s")


@dataclass
class FaultBench:
    """Where a fault runs: sample records, a run root, the environment of every process."""

    root: Path
    records: Path
    env: dict[str, str]
    processes: list[subprocess.Popen] = field(default_factory=list)

    @classmethod
    def make(cls, root: Path, per_class: int = 2) -> FaultBench:
        """Sample records written once; the processes' temp folder is ``root/tmp`` (their
        scratch folders are looked at there) and Redis is waited for up to 60 s."""
        env = {**os.environ, "TMPDIR": str(root / "tmp"), OUTAGE_ENV: "60"}
        (root / "tmp").mkdir(parents=True, exist_ok=True)
        records = root / "records"
        subprocess.run([*CLI, "sample-data", str(records), "--per-class", str(per_class)],
                       env=env, check=True, stdout=subprocess.DEVNULL)
        return cls(root, records, env)

    def worker(self, url: str, *extra: str) -> subprocess.Popen:
        """A ``scenweave worker`` quick to notice abandoned jobs (heartbeat 1 s)."""
        process = subprocess.Popen(
            [*CLI, "worker", "--queue", url, "--heartbeat", "1", "--maintenance-interval", "1",
             *extra], env=self.env, cwd=self.root, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True)
        self.processes.append(process)
        return process

    def submit(self, url: str, run_id: str, *extra: str) -> subprocess.Popen:
        """``scenweave submit RECORDS --no-llm --run-id RUN_ID`` (add ``--wait`` to wait)."""
        process = subprocess.Popen(
            [*CLI, "submit", str(self.records), "--no-llm", "--out", str(self.root / "runs"),
             "--queue", url, "--run-id", run_id, "--classes", ",".join(CLASSES), *extra],
            env=self.env, cwd=self.root, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True)
        self.processes.append(process)
        return process

    def stop(self) -> None:
        """SIGTERM every process still running (RQ: warm shutdown), SIGKILL the stubborn."""
        stop_processes(self.processes)


def delivery(fault: str, run: Path) -> Delivery:
    """Count the run folder's scenarios: once, doubled (two folders of one scenario), lost
    (fewer distinct scenarios than ``run.json`` expects), those not ok and those not whole
    (``folder_damage``: a file the outcome names missing or unreadable)."""
    expected = int(json.loads((run / RUN_FILE).read_text())["scenarios"])
    folders = {p.parent: json.loads(p.read_text()) for p in sorted(run.glob(f"*/{STATUS_NAME}"))}
    outcomes = list(folders.values())
    seen = Counter(o["scenario_id"] for o in outcomes)
    return Delivery(fault, expected, once=sum(n == 1 for n in seen.values()),
                    lost=max(expected - len(seen), 0), doubled=sum(n > 1 for n in seen.values()),
                    not_ok=sorted(o["scenario_id"] for o in outcomes if o["status"] != "ok"),
                    damaged=sorted(o["scenario_id"] for folder, o in folders.items()
                                   if folder_damage(folder, o)))


def wait_for(condition: Callable[[], object], timeout_s: float, what: str) -> None:
    """Poll ``condition`` every 0.1 s; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def committed(run: Path) -> int:
    """How many scenario folders the run folder holds now."""
    return len(list(run.glob(f"*/{STATUS_NAME}")))


def finish(process: subprocess.Popen, timeout_s: float = 240) -> tuple[int, str]:
    """Wait for ``process``; its exit code and everything it printed."""
    out, _ = process.communicate(timeout=timeout_s)
    return process.returncode, out or ""


def redis_restart(bench: FaultBench, appendonly: bool, outage_s: float = 2.0) -> Delivery:
    """Two workers and ``submit --wait``; Redis SIGKILLed once two scenarios are in and
    restarted ``outage_s`` later. Without its append-only file Redis comes back empty: the
    submitter names the lost scenarios and exits 1, and the one step it names (submit the
    same --run-id again) finishes the run."""
    name = f"redis-{'aof' if appendonly else 'bare'}"
    server = RedisServer(bench.root / name, appendonly=appendonly).start()
    try:
        workers = [bench.worker(server.url), bench.worker(server.url)]
        wait_for(lambda: _idle_workers(server.url) >= 2, 120, "two idle workers")
        run = bench.root / "runs" / name
        submitter = bench.submit(server.url, name, "--wait")
        wait_for(lambda: run.is_dir() and committed(run) >= 2, 120, "two scenarios in")
        server.kill()
        time.sleep(outage_s)
        server.start()
        back = time.monotonic()
        codes, output = _until_done(bench, server.url, name, submitter)
        kept = "appendonly" if appendonly else "no persistence"
        result = delivery(f"Redis SIGKILL + restart ({kept})", run)
        result.exit_codes, result.output = codes, output
        result.recover_s = time.monotonic() - back
        result.output += "".join(_stopped(workers))
        return result
    finally:
        bench.stop()
        server.stop()


def _until_done(bench: FaultBench, url: str, run_id: str,
                submitter: subprocess.Popen) -> tuple[list[int], str]:
    """The submitter's exit code, and, when it says to submit again, that submit's."""
    code, output = finish(submitter)
    codes = [code]
    if code != 0 and "submit the same --run-id again" in output:
        again, more = finish(bench.submit(url, run_id, "--wait"))
        codes.append(again)
        output += more
    return codes, output


def _stopped(workers: list[subprocess.Popen]) -> list[str]:
    """What each worker printed, noting any that ended on its own (no worker should)."""
    lines = []
    for number, process in enumerate(workers):
        ended = process.poll()
        if ended is not None:
            lines.append(f"worker {number} ended by itself with {ended}\n")
    return lines


def _idle_workers(url: str) -> int:
    from redis import Redis
    from rq import Worker

    return sum(w.get_state() == "idle" for w in Worker.all(connection=Redis.from_url(url)))


def forks(pid: int) -> list[int]:
    """The live processes forked by ``pid`` (its children running its own command line, as
    RQ's scheduler does; not the programs it started, such as esmini)."""
    found = []
    command = Path(f"/proc/{pid}/cmdline").read_bytes()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rpartition(")")[2].split()
            same = (stat.parent / "cmdline").read_bytes() == command
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z" and same:
            found.append(int(stat.parent.name))
    return found


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    except OSError:
        return False
    return state != "Z"


@dataclass
class KilledWorker:
    """What a worker killed mid-job left: its scheduler, its scratch folders."""

    delivery: Delivery
    scheduler_pids: list[int]
    schedulers_alive_after_kill: list[int]
    scratch_after_kill: list[str]
    scratch_after_next_start: list[str]


def worker_killed(bench: FaultBench) -> KilledWorker:
    """A worker (with its RQ scheduler) SIGKILLed while a job of the run is started; a new
    worker then starts, sweeps the dead one's scratch and redoes the abandoned job."""
    server = RedisServer(bench.root / "redis-kill").start()
    run = bench.root / "runs" / "killed"
    try:
        doomed = bench.worker(server.url)
        wait_for(lambda: _idle_workers(server.url) >= 1, 120, "an idle worker")
        wait_for(lambda: forks(doomed.pid), 30, "the worker's scheduler process")
        schedulers = forks(doomed.pid)
        code, output = finish(bench.submit(server.url, "killed"))
        if code != 0:
            raise AssertionError(f"submit failed ({code}): {output}")
        wait_for(lambda: _started_jobs(server.url), 60, "a started job")
        dead_scratch = _owned_by(bench.root / "tmp", doomed.pid)
        doomed.kill()
        doomed.wait()
        killed_at = time.monotonic()
        time.sleep(1.0)  # the kernel's SIGTERM to the orphans, and their warm shutdown
        with suppress(AssertionError):  # one left alive is what is measured, not a crash
            wait_for(lambda: not any(alive(p) for p in schedulers), 10, "the scheduler to end")
        left = [p for p in schedulers if alive(p)]
        for orphan in left:  # ours to end: no process of the fault outlives it
            os.kill(orphan, signal.SIGKILL)
        after_kill = [p.name for p in dead_scratch if p.exists()]
        bench.worker(server.url)
        wait_for(lambda: _idle_workers(server.url) >= 1, 120, "the next worker")
        after_start = [p.name for p in dead_scratch if p.exists()]
        code, output = finish(bench.submit(server.url, "killed", "--wait"))
        result = delivery("worker SIGKILL mid-job", run)
        result.exit_codes, result.output = [code], output
        result.recover_s = time.monotonic() - killed_at
        return KilledWorker(result, schedulers, left, after_kill, after_start)
    finally:
        bench.stop()
        server.stop()


def _started_jobs(url: str) -> int:
    from redis import Redis
    from rq import Queue

    from scenweave.queue.connection import QUEUE_NAME

    return len(Queue(QUEUE_NAME, connection=Redis.from_url(url)).started_job_registry)


def _owned_by(tmp: Path, pid: int) -> list[Path]:
    """The scratch folders (the worker's own and the player's) of process ``pid``."""
    return sorted(p for p in (tmp / "scenweave-scratch").glob(f"*-{pid}-*") if p.is_dir())

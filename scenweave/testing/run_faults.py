"""Faults injected into a real ``scenweave run`` and a real worker, for the fault suite
(``tests/faults/``) and ``benchmarks/faults.py``, beside the queue's (``testing.faults``):

- ``run`` SIGKILLed mid-batch, then ``run --resume``;
- the run's disk full (a small tmpfs mounted under the bench; needs root, or CAP_SYS_ADMIN),
  then the step the error line names, once there is more space;
- esmini itself crashing (SIGSEGV) mid-replay: the player server's children are signalled
  from outside, no hook in the player;
- a ``scenweave worker`` started while its Redis is down, which must wait for it;
- a finished run's folders damaged, then the same command again.

Each ends in a ``Delivery`` (once / lost / doubled / half-written, exit codes, seconds to
recover).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

from scenweave.schemas.scenario_folder import PARAMS_NAME, STAGING_DIR, STATUS_NAME, XOSC_NAME
from scenweave.testing.faults import (
    CLASSES,
    CLI,
    Delivery,
    FaultBench,
    alive,
    committed,
    delivery,
    finish,
    forks,
    wait_for,
)
from scenweave.testing.processes import stop_processes
from scenweave.testing.redis_server import RedisServer

#: the line a run prints as it starts (``RunFolder.announce``): its id
STARTED = re.compile(r"^run (\S+): (?:started|resumed) in ")
#: what the player server's command line runs (``player.engine.serve``); its forks play
PLAYER_SERVER = b"import serve"


def run_command(bench: FaultBench, out: Path, *extra: str) -> subprocess.Popen:
    """``scenweave run RECORDS --no-llm --out OUT`` over the bench's classes; stdout and
    stderr apart (the run's id is the first line on stderr)."""
    process = subprocess.Popen(
        [*CLI, "run", str(bench.records), "--no-llm", "--out", str(out), "--classes",
         ",".join(CLASSES), *extra], env=bench.env, cwd=bench.root, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    bench.processes.append(process)
    return process


def finish_run(process: subprocess.Popen, timeout_s: float = 300) -> tuple[int, str]:
    """Wait for a run; its exit code and what it printed, stdout then stderr."""
    out, err = process.communicate(timeout=timeout_s)
    return process.returncode, (out or "") + (err or "")


def announced_run_id(process: subprocess.Popen) -> str:
    """The run id a starting run prints as its first stderr line (also when not on a
    terminal: here stderr is a pipe)."""
    assert process.stderr is not None
    line = process.stderr.readline()
    found = STARTED.match(line)
    if not found:
        raise AssertionError(f"the run did not start with its id: {line!r}")
    return found.group(1)


def leftovers(run: Path) -> list[str]:
    """What a finished run must not hold any more: its staging folder (half-made scenarios
    of a killed or stopped process, which the next start of the run removes)."""
    return [p.name for p in run.iterdir() if p.name == STAGING_DIR]


def run_killed(bench: FaultBench, after: int = 2) -> Delivery:
    """``run`` SIGKILLed once ``after`` scenarios are in; then ``run --resume``, which must
    find that run, keep what was done and make the rest, each once."""
    out = bench.root / "runs-killed"
    first = run_command(bench, out)
    run_id = announced_run_id(first)
    run = out / run_id
    wait_for(lambda: committed(run) >= after, 240, f"{after} scenarios in")
    first.kill()
    code, said = finish_run(first)
    killed_at = time.monotonic()
    kept = delivery("run SIGKILL mid-batch, then --resume", run)
    again = run_command(bench, out, "--resume")
    resumed_code, output = finish_run(again)
    result = delivery("run SIGKILL mid-batch, then --resume", run)
    result.exit_codes, result.recover_s = [code, resumed_code], time.monotonic() - killed_at
    result.output = (f"kept after the kill: {kept.once} whole, {len(kept.damaged)} "
                     f"half-written\n{said}{output}")
    result.damaged += leftovers(run)
    return result


def mount_problem() -> str | None:
    """Why a tmpfs cannot be mounted here (not root, no CAP_SYS_ADMIN, no ``mount``), or
    None when it can."""
    if shutil.which("mount") is None or shutil.which("umount") is None:
        return "no mount/umount program"
    if os.geteuid() != 0:
        return "mounting a tmpfs needs root (or CAP_SYS_ADMIN); this user is not"
    probe = Path(f"/tmp/scenweave-mount-probe-{os.getpid()}")
    probe.mkdir(exist_ok=True)
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(probe)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            return f"mount -t tmpfs was refused: {done.stderr.strip()}"
        subprocess.run(["umount", str(probe)], check=True)
        return None
    finally:
        probe.rmdir()


def disk_full(bench: FaultBench, size_kib: int = 600) -> Delivery:
    """``run`` into a ``size_kib`` tmpfs until its disk is full: exit 1, one line naming the
    run, its folder and the step that resumes it; that step, once the tmpfs is grown, must
    finish the run with each scenario once."""
    disk = bench.root / "small-disk"
    disk.mkdir(exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kib}k,mode=0755", "tmpfs",
                    str(disk)], check=True)
    try:
        code, said = finish_run(run_command(bench, disk, "--run-id", "full"))
        full_at = time.monotonic()
        kept = delivery("disk full (ENOSPC), then the named step", disk / "full")
        subprocess.run(["mount", "-o", "remount,size=64m", str(disk)], check=True)
        step = resume_step(said)
        again_code, output = finish_run(run_command(bench, disk, *step))
        result = delivery("disk full (ENOSPC), then the named step", disk / "full")
        result.exit_codes, result.recover_s = [code, again_code], time.monotonic() - full_at
        result.output = (f"kept when the disk was full: {kept.once} whole, "
                         f"{len(kept.damaged)} half-written\n{said}{output}")
        result.damaged += leftovers(disk / "full")
        return result
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def resume_step(output: str) -> list[str]:
    """The options the stopped run's error line says to rerun with (``--run-id ID``)."""
    found = re.search(r"run the same command with (--run-id \S+) to resume", output)
    if not found:
        raise AssertionError(f"no step to resume in: {output}")
    return found.group(1).split()


def esmini_crashed(bench: FaultBench) -> tuple[Delivery, dict]:
    """esmini crashes (SIGSEGV from outside) in every replay until the first scenario is in:
    that one scenario fails with a finding saying so, the batch goes on, exit 1. Also the
    crashed scenario's outcome."""
    out = bench.root / "runs-crash"
    process = run_command(bench, out, "--run-id", "crash")
    run = out / "crash"
    crashes: list[float] = []
    crasher = threading.Thread(target=_crash_players, args=(process, run, crashes), daemon=True)
    crasher.start()
    code, output = finish_run(process)
    crasher.join()
    result = delivery("esmini SIGSEGV mid-replay", run)
    result.recover_s = _first_commit_after(run, crashes[-1]) if crashes else 0.0
    outcomes = [json.loads(p.read_text()) for p in sorted(run.glob(f"*/{STATUS_NAME}"))]
    failed = [o for o in outcomes if o["status"] == "failed"]
    why = "".join(f"{o['scenario_id']}: {e['message']}\n" for o in failed
                  for e in (o.get("validation") or {}).get("errors", []))
    result.exit_codes = [code]
    result.output = f"esmini children crashed: {len(crashes)}\n{why}{output}"
    return result, (failed[0] if failed else {})


def _crash_players(process: subprocess.Popen, run: Path, crashes: list[float]) -> None:
    """SIGSEGV every esmini child of the run's player server that is playing until a
    scenario is committed (both plays of the first scenario: on the cut map and again on
    the whole map). A child forked ahead and still waiting for its scenario is left alone:
    the fault is a crash mid-replay."""
    while process.poll() is None and not (run.is_dir() and committed(run)):
        for player in _players(process.pid):
            if alive(player) and _playing(player):
                os.kill(player, signal.SIGSEGV)
                crashes.append(time.time())
        time.sleep(0.005)


def _players(run_pid: int) -> list[int]:
    """The esmini children of ``run_pid``'s player server (forks of it)."""
    servers = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parent = int(stat.read_text().rpartition(")")[2].split()[1])
            if parent == run_pid and PLAYER_SERVER in (stat.parent / "cmdline").read_bytes():
                servers.append(int(stat.parent.name))
        except (OSError, ValueError, IndexError):
            continue
    return [child for server in servers for child in _forks_quietly(server)]


def _playing(pid: int) -> bool:
    """Whether the player child ``pid`` plays a scenario: esmini holds its log open then."""
    try:
        return any(os.readlink(fd).endswith(".log") for fd in Path(f"/proc/{pid}/fd").iterdir())
    except OSError:  # it ended meanwhile
        return False


def _forks_quietly(pid: int) -> list[int]:
    try:
        return forks(pid)
    except OSError:  # the server ended meanwhile
        return []


def _first_commit_after(run: Path, at: float) -> float:
    """Seconds from ``at`` (wall clock) to the first ok scenario committed after it: the
    batch going on past the crashed one."""
    after = sorted(p.stat().st_mtime for p in run.glob(f"*/{STATUS_NAME}")
                   if p.stat().st_mtime > at
                   and json.loads(p.read_text(encoding="utf-8"))["status"] == "ok")
    return after[0] - at if after else 0.0


def worker_before_redis(bench: FaultBench, down_s: float = 3.0) -> Delivery:
    """A worker started while its Redis is down waits (saying so once) instead of failing:
    once it says it waits, Redis stays down ``down_s`` more; then ``submit --wait`` is
    served by it, each scenario once."""
    server = RedisServer(bench.root / "redis-late")
    try:
        worker = bench.worker(server.url)
        said = _lines_of(worker)
        wait_for(lambda: any("does not answer" in line for line in said), 120,
                 "the worker to say it waits for Redis")
        time.sleep(down_s)
        waited = worker.poll() is None
        server.start()
        up_at = time.monotonic()
        code, output = finish(bench.submit(server.url, "late", "--wait"))
        result = delivery("worker started before Redis", bench.root / "runs" / "late")
        result.exit_codes, result.recover_s = [code], time.monotonic() - up_at
        stop_processes([worker])
        result.output = (f"worker still waiting {down_s:g} s after saying so: {waited}\n"
                         f"{''.join(said)}{output}")
        return result
    finally:
        bench.stop()
        server.stop()


def _lines_of(process: subprocess.Popen) -> list[str]:
    """Every line ``process`` prints, collected as it prints them (by a thread that ends
    with the process's output)."""
    lines: list[str] = []
    stream = process.stdout

    def collect() -> None:
        for line in stream or ():
            lines.append(line)

    threading.Thread(target=collect, daemon=True).start()
    return lines


def damaged_on_resume(bench: FaultBench) -> tuple[Delivery, list[str]]:
    """A finished run, then three of its folders damaged (status.json truncated,
    scenario.xosc deleted, params.json not JSON), then the same command again: the damaged
    ones, named on the console, are made again and the whole ones left alone. Also the
    damaged scenarios' folder names."""
    out = bench.root / "runs-damaged"
    first, said = finish_run(run_command(bench, out, "--run-id", "damaged"))
    run = out / "damaged"
    folders = sorted(p.parent for p in run.glob(f"*/{STATUS_NAME}"))
    truncated, unscenario, unparams = folders[:3]
    (truncated / STATUS_NAME).write_text('{"scenario_id": ', encoding="utf-8")
    (unscenario / XOSC_NAME).unlink()
    (unparams / PARAMS_NAME).write_text("[1, 2", encoding="utf-8")
    damaged_at = time.monotonic()
    again, output = finish_run(run_command(bench, out, "--run-id", "damaged"))
    result = delivery("damaged folders on resume", run)
    result.exit_codes, result.recover_s = [first, again], time.monotonic() - damaged_at
    result.output = said + output
    return result, [p.name for p in (truncated, unscenario, unparams)]

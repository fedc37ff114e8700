"""Resource attacks an LLM-written script could make, run on both backends: forks, memory,
CPU, time, daemons, output, disk.

Each is judged on the host — the process table, the kernel's CPU accounting, the sandbox's
own files seen through ``/proc/<pid>/root`` while it is held open, the engine's log file —
and each shows it really reached its limit, so a limit set far too high fails as well.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import time
import uuid
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from docker.errors import NotFound

from scenweave.sandbox import SandboxSettings, get_sandbox
from scenweave.sandbox.cgroups import RunCgroup, run_name
from scenweave.sandbox.container import owner_labels
from scenweave.sandbox.settings import MIB
from tests.sandbox.conftest import FAST
from tests.sandbox.evidence import (
    bytes_under,
    cpu_seconds,
    held_run,
    marker,
    members,
    pids_cgroup,
    processes_with,
    run_seeing_processes,
    survivors,
    wait_for_processes,
)

#: forks sleepers tagged with params["tag"] until refused; writes how many it got, and
#: gives the host a second to see them
FORK_BOMB = """
import os, time
def generate(params, out_path):
    forks = 0
    for _ in range(2000):
        try:
            if os.fork() == 0:
                os.execv("/bin/sleep", [params["tag"], "300"])
            forks += 1
        except OSError:
            break
    open(out_path, "w").write(str(forks))
    time.sleep(1)
"""
#: FORK_BOMB that then keeps its sleepers until the host kills them
HOLDING_FORK_BOMB = FORK_BOMB.replace("    time.sleep(1)\n", """    while True:
        try:
            os.wait()
        except ChildProcessError:
            break
""")
#: what any script may do: start a few processes
BENIGN_FORKS = """
import os, subprocess
def generate(params, out_path):
    children = []
    for _ in range(4):
        child = os.fork()
        if child == 0:
            os._exit(0)
        children.append(child)
    for child in children:
        os.waitpid(child, 0)
    echoed = subprocess.run(["/bin/echo", "and ran echo"], capture_output=True, text=True)
    open(out_path, "w").write(f"forked {len(children)} {echoed.stdout.strip()}")
"""
#: benign attempts running beside the fork bomb: as many as a batch's workers run at once
BESIDE_THE_BOMB = 4
#: allocates (and touches) 8 MiB at a time, printing the running total, up to 512 MiB
MEMORY_BOMB = """
def generate(params, out_path):
    hog = []
    for _ in range(64):
        hog.append(bytearray(8 << 20))
        print("allocated", 8 * len(hog), "MiB", flush=True)
"""
FILL_CHUNK = 256 * 1024
#: writes FILL_CHUNK files into /out and /tmp and appends to the report file until refused
#: (or params["limit"] bytes each, far above the caps), then holds the sandbox open
DISK_FILL = f"""
def fill(path, limit, append):
    try:
        for index in range(limit // {FILL_CHUNK}):
            name = path if append else f"{{path}}/fill{{index}}"
            with open(name, "ab" if append else "wb") as handle:
                handle.write(b"x" * {FILL_CHUNK})
    except OSError:
        pass

def generate(params, out_path):
    fill("/out", params["limit"], append=False)
    fill("/tmp", params["limit"], append=False)
    fill("/sandbox/result.json", params["limit"], append=True)
    hold(params["tag"])
"""


def test_fork_bomb_is_capped_and_leaves_no_process(make_box, tmp_path):
    box = make_box(pids=24)
    tag = marker()
    result = run_seeing_processes(box, FORK_BOMB, {"tag": tag}, tmp_path, count=8)
    assert processes_with(tag) == []
    assert result.ok, result
    assert 0 < int((tmp_path / "scenario.xosc").read_text()) < 24


def test_a_fork_bomb_starves_no_concurrent_sandbox(make_box, tmp_path):
    """The process cap is per sandbox: while a fork bomb holds every process it could get,
    attempts beside it (all as the same uid) still start and fork."""
    box = make_box(pids=32, wall_time_s=60.0)
    tag = marker()
    with ThreadPoolExecutor(max_workers=1 + BESIDE_THE_BOMB) as pool:
        bomb = pool.submit(box.run, HOLDING_FORK_BOMB, {"tag": tag}, tmp_path / "bomb")
        try:
            wait_for_processes(tag, bomb, count=24)
            benign = [pool.submit(box.run, BENIGN_FORKS, {}, tmp_path / str(index))
                      for index in range(BESIDE_THE_BOMB)]
            results = [future.result() for future in benign]
            held = processes_with(tag)  # the bomb still held its processes at the end
        finally:
            for pid in processes_with(tag):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
        bombed = bomb.result()
    assert [r.error_message for r in results if not r.ok] == [], results
    assert {(tmp_path / str(i) / "scenario.xosc").read_text()
            for i in range(BESIDE_THE_BOMB)} == {"forked 4 and ran echo"}
    assert len(held) >= 24, "the bomb let go of its processes before the others ran"
    assert bombed.ok and 24 <= int((tmp_path / "bomb" / "scenario.xosc").read_text()) < 32


def test_run_returns_once_every_process_and_the_cgroup_of_a_timed_out_attempt_is_gone(
        make_box, tmp_path):
    box = make_box(wall_time_s=5.0)  # a cold container takes ~2 s to reach generate()
    tag = marker()
    code = """
import os, time
def generate(params, out_path):
    for _ in range(3):
        if os.fork() == 0:
            os.execv("/bin/sleep", [params["tag"], "300"])
    time.sleep(300)
"""
    with ThreadPoolExecutor(max_workers=1) as pool:
        running = pool.submit(box.run, code, {"tag": tag}, tmp_path)
        cgroup = pids_cgroup(wait_for_processes(tag, running, count=3)[0])
        attempt = members(cgroup)  # the sandbox's PID 1 (the harness) and the sleepers
        result = running.result()
    assert result.timed_out, result
    assert survivors(attempt) == [], "left behind (zombies count) when run() returned"
    assert not cgroup.exists(), f"the attempt's cgroup {cgroup} survived run()"
    assert len(attempt) >= 4


def allocated_mib(stdout: str) -> int:
    """The last running total the memory bomb printed (0 when it printed none)."""
    return max(map(int, re.findall(r"allocated (\d+) MiB", stdout)), default=0)


def test_memory_bomb_is_killed_at_the_memory_limit(make_box, tmp_path):
    box = make_box(memory_mb=128)
    here = set(Path.cwd().iterdir())
    result = box.run(MEMORY_BOMB, {}, tmp_path)
    assert not result.ok and not result.timed_out
    assert result.error_type in ("Killed", "MemoryError"), result
    # it got going, and was stopped below the 128 MiB cap (the interpreter uses some too)
    assert 32 <= allocated_mib(result.stdout) < 128, result.stdout
    # the engine's side effects (podman's conmon writes an empty 'oom' into the API service's
    # working folder) stay out of the folder the user works in
    assert set(Path.cwd().iterdir()) == here


@pytest.mark.parametrize("body", ["while True:\n        pass", "import time; time.sleep(120)"],
                         ids=["cpu-burn", "sleep"])
def test_runaway_script_is_killed_at_the_wall_time(make_box, tmp_path, body):
    box = make_box(wall_time_s=2.0)
    started = time.monotonic()
    result = box.run(f"def generate(params, out_path):\n    {body}\n", {}, tmp_path)
    assert result.timed_out and result.error_type == "Timeout"
    assert "SandboxSettings.wall_time_s" in result.error_message
    assert time.monotonic() - started < 2.0 + 5.0


def test_busy_processes_share_the_cpu_quota_and_none_survives(make_box, tmp_path):
    cpus = 0.25  # far below what two busy processes get on any idle or busy host
    box = make_box(cpus=cpus, wall_time_s=10.0)
    tag = marker()
    code = """
import os, sys, time
def generate(params, out_path):
    for _ in range(2):
        if os.fork() == 0:
            os.execv(sys.executable, [sys.executable, "-c", "while True: pass", params["tag"]])
    time.sleep(3)
"""
    with ThreadPoolExecutor(max_workers=1) as pool:
        running = pool.submit(box.run, code, {"tag": tag}, tmp_path)
        hogs = wait_for_processes(tag, running, count=2)
        time.sleep(0.3)
        used, started = cpu_seconds(hogs), time.monotonic()
        time.sleep(1.5)
        rate = (cpu_seconds(hogs) - used) / (time.monotonic() - started)
        result = running.result()
    assert result.ok, result
    assert processes_with(tag) == []  # the busy children were killed with the sandbox
    assert 0.4 * cpus <= rate <= 1.3 * cpus + 0.05, f"{rate:.2f} CPUs used"


def test_daemon_does_not_outlive_the_attempt(box, tmp_path):
    tag = marker()
    code = """
import os, signal, time
def generate(params, out_path):
    if os.fork() == 0:
        os.setsid()
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        if os.fork() == 0:
            os.execv("/bin/sleep", [params["tag"], "300"])
        os._exit(0)
    open(out_path, "w").write("daemon started")
    time.sleep(1)  # the host sees the daemon alive
"""
    result = run_seeing_processes(box, code, {"tag": tag}, tmp_path, count=1)
    assert result.ok, result
    assert processes_with(tag) == []


def test_output_flood_is_capped(make_box, tmp_path):
    box = make_box(wall_time_s=20.0)  # the flood must end on its own, not at the time limit
    code = """
import sys
def generate(params, out_path):
    sys.stdout.write("HEAD" + "x" * (1 << 20))
    for _ in range(16):
        sys.stdout.write("y" * (1 << 20))
    sys.stdout.write("TAIL")
    sys.stderr.write("e" * (8 << 20))
"""
    result = box.run(code, {}, tmp_path)
    cap = box.settings.stdout_max_bytes
    assert result.stdout.startswith("HEAD") and result.stdout.endswith("TAIL")
    assert "bytes cut by the sandbox" in result.stdout
    assert len(result.stdout) < cap + 100 and len(result.stderr) < cap + 100


def test_output_flood_leaves_no_big_container_log(make_docker_box, tmp_path):
    box = make_docker_box(wall_time_s=20.0)
    code = """
import sys
def generate(params, out_path):
    for _ in range(16):
        sys.stdout.write("y" * (1 << 20))
    sys.stdout.flush()
    hold(params["tag"])
"""

    def log_file(pid: int) -> tuple[Path, int]:
        time.sleep(0.5)  # let the engine catch up with the flood
        containers = box.client.containers.list(filters={"label": "scenweave.sandbox"})
        log = next(Path(c.attrs["LogPath"]) for c in containers if c.attrs["State"]["Pid"] == pid)
        return log, log.stat().st_size

    result, (log, size) = held_run(box, code, {"tag": marker()}, tmp_path, log_file)
    assert "bytes cut by the sandbox" in result.stdout  # the 16 MiB flood did go out
    assert 0 < size <= 2 * MIB, f"container log {log} holds {size} bytes"
    assert not log.parent.exists(), "the container's storage survived the attempt"


def check_disk_fill_stops_at_the_caps(box, tmp_path: Path) -> None:
    """Fill /out, /tmp and the report file in ``box`` (staged in its own ``work_dir``) and
    check from the host that each stopped at its cap, not at the host's free space."""
    s = box.settings
    caps = {"out": s.output_max_bytes, "tmp": s.tmpfs_mb * MIB, "report": s.file_size_limit}
    free_before = shutil.disk_usage(s.work_dir).free

    def sizes(pid: int) -> dict[str, int]:
        root = Path(f"/proc/{pid}/root")
        report = sum(p.stat().st_size for p in s.work_dir.glob("*/result.json"))
        return {"out": bytes_under(root / "out"), "tmp": bytes_under(root / "tmp"),
                "report": report}

    params = {"tag": marker(), "limit": 4 * max(caps.values())}
    _, filled = held_run(box, DISK_FILL, params, tmp_path / "out", sizes)
    for place, cap in caps.items():
        assert cap - 2 * FILL_CHUNK <= filled[place] <= cap, (place, filled, caps)
    assert free_before - shutil.disk_usage(s.work_dir).free < 256 * MIB


def test_disk_fill_stops_at_the_output_limit(make_box, tmp_path, work_dir):
    box = make_box(output_max_bytes=16 * MIB, tmpfs_mb=8, work_dir=work_dir)
    check_disk_fill_stops_at_the_caps(box, tmp_path)


def test_without_a_cgroup_rlimits_still_stop_bombs(tmp_path, work_dir):
    """Hosts where no run cgroup can be made (non-root, no delegation) fall back to rlimits."""
    if shutil.which("bwrap") is None:
        pytest.skip("BWRAP BACKEND NOT TESTED: bubblewrap is not installed")
    settings = SandboxSettings(backend="bwrap", cgroup_root=tmp_path / "no-cgroups",
                               work_dir=work_dir,
                               **{**FAST, "pids": 16, "memory_mb": 64})
    box = get_sandbox(settings)
    assert "no cgroup controller" in box.cgroup_problem
    tag = marker()
    forks = run_seeing_processes(box, FORK_BOMB, {"tag": tag}, tmp_path / "fork", count=4)
    assert processes_with(tag) == []
    assert forks.ok and 0 < int((tmp_path / "fork" / "scenario.xosc").read_text()) < 16
    memory = box.run(MEMORY_BOMB, {}, tmp_path / "mem")
    assert memory.error_type == "MemoryError"
    assert 32 <= allocated_mib(memory.stdout) <= 4 * settings.memory_mb  # the address-space cap
    check_disk_fill_stops_at_the_caps(box, tmp_path)


@pytest.fixture
def cgroup_root() -> Path:
    """The host's cgroup tree, where the bwrap backend makes its run cgroups."""
    root = SandboxSettings().cgroup_root
    if shutil.which("bwrap") is None:
        pytest.skip("BWRAP BACKEND NOT TESTED: bubblewrap is not installed")
    if (problem := RunCgroup.unavailable_reason(root)) is not None:
        pytest.skip(f"RUN CGROUPS NOT TESTED: {problem}")
    return root


def test_run_cgroups_of_dead_owners_are_swept_at_the_next_start(cgroup_root, tmp_path):
    """A worker killed from outside leaves its run cgroup behind: the next sandbox start kills
    what is left in it and removes it, but never touches a live worker's."""
    dead_owner = subprocess.Popen(["sleep", "60"])
    stale = RunCgroup(cgroup_root, run_name(dead_owner.pid))
    dead_owner.kill()
    dead_owner.wait()
    live_owner = subprocess.Popen(["sleep", "60"])
    kept = [RunCgroup(cgroup_root, run_name(live_owner.pid)),
            RunCgroup(cgroup_root, f"run-{uuid.uuid4().hex[:12]}")]  # no owner in the name
    orphan = None
    try:
        for cgroup in (stale, *kept):
            cgroup.create(64 * MIB, 8, 1.0)
        orphan = subprocess.Popen(["sleep", "60"])  # a sandbox process that outlived its owner
        for procs in stale.procs_files():
            procs.write_text(str(orphan.pid))
        get_sandbox(SandboxSettings(backend="bwrap", **FAST)).close()
        assert [folder for folder in stale.folders if folder.exists()] == []
        assert orphan.wait(timeout=5) == -signal.SIGKILL
        assert [folder for cgroup in kept for folder in cgroup.folders if
                not folder.is_dir()] == []
    finally:
        for process in (live_owner, orphan):
            if process is not None:
                process.kill()
                process.wait()
        for cgroup in (stale, *kept):
            cgroup.remove()


def test_containers_of_dead_owners_are_removed_at_the_next_start(make_docker_box):
    """A process killed from outside leaves its containers (a warm one, a running attempt):
    the next start on this host removes them, but never a live process's."""
    box = make_docker_box()
    owners = {"dead": subprocess.Popen(["sleep", "60"]), "live": subprocess.Popen(["sleep", "60"])}
    containers = {name: box.client.containers.create(
        box.settings.image, command=["sleep", "60"], labels=owner_labels(owner.pid),
        network_mode="none", ulimits=box._ulimits(), user="65534:65534")
        for name, owner in owners.items()}
    owners["dead"].kill()
    owners["dead"].wait()
    try:
        for container in containers.values():
            container.start()
        make_docker_box()
        left = {c.id for c in box.client.containers.list(all=True)}
        assert containers["dead"].id not in left
        assert containers["live"].id in left
    finally:
        owners["live"].kill()
        owners["live"].wait()
        for container in containers.values():
            with contextlib.suppress(NotFound):
                container.remove(force=True)

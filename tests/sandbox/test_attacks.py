"""Attacks an LLM-written script could make, run on both backends.

Each attack is judged at the receiver on the host — a loopback listener, a canary secret, a
marker file, the process table — never by what the script prints. The benign controls show
the same channels do work, so a sandbox that blocks everything fails.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.sandbox.evidence import Listener, marker, processes_with

REPO = Path(__file__).resolve().parents[2]
#: forks sleepers tagged with params["tag"] until refused; writes how many it got
FORK_BOMB = """
import os
def generate(params, out_path):
    forks = 0
    for _ in range(2000):
        try:
            if os.fork() == 0:
                os.execv("/bin/sleep", ["sleep", "300", params["tag"]])
            forks += 1
        except OSError:
            break
    open(out_path, "w").write(str(forks))
"""


def output_text(out_dir: Path) -> str:
    """Everything the host received in the output folder, as text."""
    return "".join(p.read_text(errors="replace") for p in sorted(out_dir.rglob("*"))
                   if p.is_file() and not p.is_symlink())


def test_benign_script_runs_and_its_output_arrives(box, tmp_path):
    code = """
import os
import scenariogeneration
def generate(params, out_path):
    print("stdout says", params["text"])
    os.makedirs(os.path.dirname(out_path) + "/extra")
    open(os.path.dirname(out_path) + "/extra/note.txt", "w").write("note")
    open(out_path, "w").write(params["text"])
"""
    result = box.run(code, {"text": "<OpenSCENARIO/>"}, tmp_path)
    assert result.ok, result
    assert (tmp_path / "scenario.xosc").read_text() == "<OpenSCENARIO/>"
    assert (tmp_path / "extra" / "note.txt").read_text() == "note"
    assert sorted(result.files) == [tmp_path / "extra" / "note.txt", tmp_path / "scenario.xosc"]
    assert "stdout says <OpenSCENARIO/>" in result.stdout
    assert 0 < result.script_duration_s <= result.duration_s


def test_script_errors_come_back_as_values(box, tmp_path):
    code = "def generate(params, out_path):\n    return params['missing_key']\n"
    result = box.run(code, {}, tmp_path)
    assert not result.ok
    assert result.exit_code == 1 and not result.timed_out
    assert (result.error_type, result.error_message) == ("KeyError", "'missing_key'")
    assert "script.py\", line 2, in generate" in result.traceback


def test_syntax_error_and_sys_exit_are_reported(box, tmp_path):
    assert box.run("def generate(:\n", {}, tmp_path).error_type == "SyntaxError"
    exiting = box.run("import sys\ndef generate(p, o):\n    sys.exit(3)\n", {}, tmp_path)
    assert (exiting.ok, exiting.error_type) == (False, "SystemExit")


def test_network_egress_reaches_no_listener(box, tmp_path):
    listener = Listener()
    code = """
import socket
def generate(params, out_path):
    for host in ("127.0.0.1", params["host_ip"]):
        try:
            socket.create_connection((host, params["tcp"]), timeout=1).sendall(b"stolen")
        except OSError:
            pass
        try:
            udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            udp.sendto(b"stolen", (host, params["udp"]))
        except OSError:
            pass
"""
    try:
        box.run(code, {"tcp": listener.tcp_port, "udp": listener.udp_port,
                       "host_ip": _host_ip()}, tmp_path)
        assert listener.received() == []
        socket.create_connection(("127.0.0.1", listener.tcp_port), timeout=1).close()
        assert listener.received() != [], "control: the listener must hear the host itself"
    finally:
        listener.close()


def test_dns_resolution_fails_and_reaches_no_resolver(box, tmp_path):
    try:  # without a resolv.conf the resolver asks 127.0.0.1:53: listen there when we can
        resolver = Listener(udp_port=53)
    except OSError:
        resolver = None
    code = """
import socket
def generate(params, out_path):
    socket.getaddrinfo("scenweave-canary.example.org", 443)
    open(out_path, "w").write("resolved")
"""
    try:
        result = box.run(code, {}, tmp_path)
        if resolver is not None:
            assert resolver.received() == []
        assert result.error_type == "gaierror"
        assert not (tmp_path / "scenario.xosc").exists()
        if resolver is not None:
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM).sendto(b"q", ("127.0.0.1", 53))
            assert resolver.received() != [], "control: the resolver must hear the host itself"
    finally:
        if resolver is not None:
            resolver.close()


def test_host_environment_and_files_stay_secret(box, tmp_path, monkeypatch):
    canary = marker()
    monkeypatch.setenv("SCENWEAVE_CANARY_SECRET", canary)
    secret_file = Path("/tmp") / f"{canary}.secret"  # world-readable on the host
    secret_file.write_text(canary)
    secret_file.chmod(0o644)
    code = """
import glob, os
def generate(params, out_path):
    loot = [repr(dict(os.environ))]
    for path in ["/proc/1/environ", "/proc/self/environ", "/proc/2/environ", params["file"],
                 *glob.glob("/tmp/*.secret"), "/etc/shadow", "/root/.bash_history",
                 params["repo_file"]]:
        try:
            loot.append(open(path, errors="replace").read())
        except OSError:
            pass
    print(loot)
    open(out_path, "w").write("\\n".join(loot))
"""
    try:
        params = {"file": str(secret_file), "repo_file": str(REPO / "pyproject.toml")}
        result = box.run(code, params, tmp_path)
    finally:
        secret_file.unlink()
    assert result.ok, result
    received = output_text(tmp_path) + result.stdout + result.stderr
    assert "PATH" in received, "control: the script did write its loot"
    assert canary not in received
    assert 'name = "scenweave"' not in received  # the repository is not mounted


def test_nothing_is_written_outside_the_output_folder(box, tmp_path):
    victim_dir = Path("/tmp") / marker()
    victim_dir.mkdir(mode=0o777)
    victim_dir.chmod(0o777)
    targets = [victim_dir / "planted", REPO / "planted-by-sandbox",
               Path(box.settings.corpus_path() or "/nonexistent") / "planted.py",
               Path("/usr/planted"), Path("/etc/planted")]
    code = """
import os
def generate(params, out_path):
    for path in params["targets"] + ["/sandbox/job/script.py", "/sandbox/job/planted"]:
        try:
            open(path, "w").write("planted")
        except OSError:
            pass
"""
    try:
        box.run(code, {"targets": [str(t) for t in targets]}, tmp_path)
        assert [t for t in targets if t.exists()] == []
        assert os.listdir(victim_dir) == []
    finally:
        shutil.rmtree(victim_dir)


def test_links_fifos_and_a_planted_link_never_lead_outside(box, tmp_path):
    victim = tmp_path.parent / f"{tmp_path.name}-victim"
    victim.write_text("untouched")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    (out_dir / "scenario.xosc").symlink_to(victim)  # planted on the host before the run
    code = """
import os
def generate(params, out_path):
    folder = os.path.dirname(out_path)
    os.symlink("/etc/passwd", folder + "/passwd.xosc")
    os.symlink("/dev/zero", folder + "/zero.xosc")
    os.symlink("/", folder + "/root")
    os.mkfifo(folder + "/fifo.xosc")
    open(out_path, "w").write("overwritten through the link?")
"""
    result = box.run(code, {}, out_dir)
    assert result.ok, result
    assert victim.read_text() == "untouched"
    assert sorted(p.name for p in out_dir.iterdir()) == ["scenario.xosc"]
    assert not (out_dir / "scenario.xosc").is_symlink()
    assert result.files == [out_dir / "scenario.xosc"]


def test_fork_bomb_is_capped_and_leaves_no_process(make_box, tmp_path):
    box = make_box(pids=24)
    tag = marker()
    result = box.run(FORK_BOMB, {"tag": tag}, tmp_path)
    assert processes_with(tag) == []
    assert result.ok, result
    assert 0 < int((tmp_path / "scenario.xosc").read_text()) < 24


def test_memory_bomb_is_killed(make_box, tmp_path):
    box = make_box(memory_mb=128)
    code = """
def generate(params, out_path):
    hog = [bytearray(32 * 1024 * 1024) for _ in range(64)]
    open(out_path, "w").write(str(len(hog)))
"""
    result = box.run(code, {}, tmp_path)
    assert not result.ok and not result.timed_out
    assert result.error_type in ("Killed", "MemoryError"), result
    assert not (tmp_path / "scenario.xosc").exists()


@pytest.mark.parametrize("body", ["while True:\n        pass", "import time; time.sleep(120)"],
                         ids=["cpu-burn", "sleep"])
def test_runaway_script_is_killed_at_the_wall_time(make_box, tmp_path, body):
    box = make_box(wall_time_s=2.0)
    started = time.monotonic()
    result = box.run(f"def generate(params, out_path):\n    {body}\n", {}, tmp_path)
    assert result.timed_out and result.error_type == "Timeout"
    assert "SandboxSettings.wall_time_s" in result.error_message
    assert time.monotonic() - started < 2.0 + 5.0


def test_daemon_does_not_outlive_the_attempt(box, tmp_path):
    tag = marker()
    code = """
import os, signal
def generate(params, out_path):
    if os.fork() == 0:
        os.setsid()
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        if os.fork() == 0:
            os.execv("/bin/sleep", ["sleep", "300", params["tag"]])
        os._exit(0)
    open(out_path, "w").write("daemon started")
"""
    result = box.run(code, {"tag": tag}, tmp_path)
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


def test_disk_fill_stops_at_the_output_limit(box, tmp_path):
    free_before = shutil.disk_usage("/").free
    code = """
import os
def generate(params, out_path):
    folder = os.path.dirname(out_path)
    for target in (folder, "/tmp", "/var/tmp", "/dev/shm", "/sandbox"):
        for i in range(2000):
            try:
                with open(f"{target}/fill{i}", "wb") as handle:
                    handle.write(b"x" * (1 << 20))
            except OSError:
                break
"""
    result = box.run(code, {}, tmp_path)
    written = sum(p.stat().st_size for p in tmp_path.rglob("*") if p.is_file())
    assert written <= box.settings.output_max_bytes
    assert free_before - shutil.disk_usage("/").free < 500 * 1024 * 1024
    assert result.exit_code is not None


def test_signalling_the_host_hits_nothing(box, tmp_path):
    bystander = subprocess.Popen(["sleep", "60"])
    code = """
import os, signal
def generate(params, out_path):
    for pid in [os.getppid(), params["host_pid"], params["bystander"], -1, 0, 1]:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
"""
    try:
        box.run(code, {"host_pid": os.getpid(), "bystander": bystander.pid}, tmp_path)
        assert bystander.poll() is None, "a host process was killed from inside the sandbox"
        os.kill(os.getpid(), 0)
    finally:
        bystander.send_signal(signal.SIGKILL)
        bystander.wait()


def test_forged_report_cannot_write_outside_or_crash_the_host(box, tmp_path):
    out_dir = tmp_path / "out"
    escape = tmp_path / "escaped.txt"
    code = """
import base64, json, os
def generate(params, out_path):
    evil = base64.b64encode(b"pwned").decode()
    report = {"error_type": None, "script_duration_s": 1e308, "traceback": ["x"] * 9,
              "files": [{"name": "../escaped.txt", "data": evil},
                        {"name": "/tmp/abs.txt", "data": evil}]}
    with open("/sandbox/result.json", "w") as handle:
        json.dump(report, handle)
    os._exit(0)
"""
    result = box.run(code, {}, out_dir)
    assert not escape.exists() and list(out_dir.iterdir()) == []
    assert not result.ok and result.error_type == "NoReport"
    assert "unsafe file name" in result.error_message


def _host_ip() -> str:
    """A non-loopback address of this host (loopback when it has none)."""
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.connect(("192.0.2.1", 9))  # no packet is sent for a UDP connect
        return probe.getsockname()[0]
    except OSError:
        return "127.0.0.1"
    finally:
        probe.close()


def test_without_a_cgroup_rlimits_still_stop_bombs(tmp_path):
    """Hosts where no run cgroup can be made (non-root, no delegation) fall back to rlimits."""
    from sandbox import SandboxSettings, get_sandbox
    from tests.sandbox.conftest import FAST

    settings = SandboxSettings(backend="bwrap", cgroup_root=tmp_path / "no-cgroups",
                               **{**FAST, "pids": 16})
    box = get_sandbox(settings)
    assert "no cgroup controller" in box.cgroup_problem
    tag = marker()
    forks = box.run(FORK_BOMB, {"tag": tag}, tmp_path / "fork")
    assert processes_with(tag) == []
    assert forks.ok and int((tmp_path / "fork" / "scenario.xosc").read_text()) < 16
    memory = box.run("def generate(p, o):\n    hog = bytearray(4 << 30)\n", {}, tmp_path / "mem")
    assert memory.error_type == "MemoryError"


def test_parallel_attempts_stay_apart(box, tmp_path):
    code = """
import time
def generate(params, out_path):
    time.sleep(0.3)
    open(out_path, "w").write(params["text"])
"""
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda i: box.run(code, {"text": f"run {i}"}, tmp_path / str(i)),
                                range(2)))
    assert [r.ok for r in results] == [True, True]
    assert [(tmp_path / str(i) / "scenario.xosc").read_text() for i in range(2)] == \
        ["run 0", "run 1"]
    assert json.loads(json.dumps(results[0].to_dict()))["files"] == \
        [str(tmp_path / "0" / "scenario.xosc")]

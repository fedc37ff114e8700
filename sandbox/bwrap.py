"""The bubblewrap backend, for hosts without a container engine.

Traps this avoids (measured, see notes/sandbox.md): bwrap started as root stays escapable, so
it is started as an unprivileged uid through ``setpriv``; the launcher's environment would leak
through ``/proc/1/environ``, so bwrap gets the sandbox environment only and ``--as-pid-1``;
bwrap sets no resource limits, so a per-run cgroup and ``prlimit`` do; bwrap's root and
``/dev`` (with ``/dev/shm``) are writable tmpfs the size of host RAM, so both are remounted
read-only; a nested user namespace could mount a tmpfs of its own, so ``--disable-userns``.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import shutil
import signal
import subprocess
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from scenweave.sandbox.attempt import (
    JOB_MOUNT,
    LIBRARY_MOUNT,
    OUT_MOUNT,
    RESULT_MOUNT,
    SANDBOX_ENV,
    Attempt,
    RawRun,
)
from scenweave.sandbox.base import Sandbox
from scenweave.sandbox.capture import CappedBuffer, drain_in_background
from scenweave.sandbox.cgroups import RunCgroup, sweep_stale
from scenweave.sandbox.errors import SandboxError, SandboxUnavailable
from scenweave.sandbox.settings import MIB

log = logging.getLogger(__name__)
#: joins the run's cgroups (as root, before dropping privileges), then execs the rest
JOIN_CGROUPS = 'while [ "$1" != -- ]; do echo $$ > "$1" || exit 125; shift; done; shift; exec "$@"'
SYSTEM_DIRS = ("bin", "sbin", "lib", "lib32", "lib64")


@dataclass
class Running:
    """A started bwrap sandbox: its launcher, cgroup and output capture."""

    proc: subprocess.Popen[bytes]
    cgroup: RunCgroup | None
    stdout: CappedBuffer
    stderr: CappedBuffer
    readers: list[threading.Thread]


class BwrapSandbox(Sandbox):
    """One bubblewrap sandbox per attempt: no network, read-only system, sized tmpfs outputs."""

    name = "bwrap"

    @functools.cached_property
    def cgroup_problem(self) -> str | None:
        """Why runs get rlimits instead of a per-run cgroup (weaker), or None."""
        return RunCgroup.unavailable_reason(self.settings.cgroup_root)

    def probe(self) -> None:
        """Check bwrap, setpriv, prlimit and the sandbox Python, then run a trivial sandbox;
        sweep the run cgroups that processes killed from outside left behind."""
        if self.cgroup_problem is None:
            for name in sweep_stale(self.settings.cgroup_root):
                log.warning("removed the run cgroup %s: the process that made it is gone", name)
        for tool in ("bwrap", "prlimit", *(["setpriv"] if os.geteuid() == 0 else [])):
            if shutil.which(tool) is None:
                raise SandboxUnavailable(f"{tool} not found: install the Debian packages in "
                                         "scripts/apt-packages.txt (bubblewrap, util-linux)")
        python = Path(self.settings.python)
        if not python.exists():
            raise SandboxUnavailable(f"sandbox Python {python} not found: create it with "
                                     "`bash scripts/setup.d/20-sandbox.sh` or set "
                                     "SandboxSettings.python")
        command = [*self._privilege_drop(), "bwrap", *self._mounts(None), "--", str(python),
                   "-I", "-c", "import scenariogeneration"]
        done = subprocess.run(command, env=SANDBOX_ENV, capture_output=True, timeout=60,
                              check=False)
        if done.returncode != 0:
            raise SandboxUnavailable(
                f"bwrap cannot start {python} with scenariogeneration as uid "
                f"{self.settings.sandbox_uid}: {done.stderr.decode(errors='replace').strip()} "
                "(it needs unprivileged user namespaces, and SandboxSettings.python and "
                "SandboxSettings.library_dir readable by SandboxSettings.sandbox_uid)")

    def _start(self, attempt: Attempt, warm: bool) -> Running:
        s = self.settings
        cgroup = None
        if self.cgroup_problem is None:
            cgroup = RunCgroup(s.cgroup_root)
            cgroup.create(s.memory_mb * MIB, s.pids, s.cpus)
        join = (["/bin/sh", "-c", JOIN_CGROUPS, "join", *map(str, cgroup.procs_files()), "--"]
                if cgroup else [])
        command = [*join, *self._privilege_drop(), *self._rlimits(cgroup is None), "bwrap",
                   *self._mounts(attempt), "--", *attempt.harness_command(s.python, warm)]
        try:
            proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                    stderr=subprocess.PIPE, bufsize=0, env=SANDBOX_ENV,
                                    close_fds=True, start_new_session=True)
        except OSError as err:
            if cgroup is not None:
                cgroup.remove()
            raise SandboxError(f"cannot start bwrap: {err}") from err
        if proc.stdout is None or proc.stderr is None:  # never: both are pipes
            raise SandboxError("bwrap started without its output pipes")
        stdout, stderr = CappedBuffer(s.stdout_max_bytes), CappedBuffer(s.stderr_max_bytes)
        readers = [drain_in_background(proc.stdout, stdout),
                   drain_in_background(proc.stderr, stderr)]
        return Running(proc, cgroup, stdout, stderr, readers)

    def _finish(self, handle: Running, started: float) -> RawRun:
        remaining = self.settings.wall_time_s - (time.monotonic() - started)
        timed_out = False
        try:
            handle.proc.wait(timeout=max(remaining, 0.01))
        except subprocess.TimeoutExpired:
            timed_out = True
        finally:
            duration = time.monotonic() - started
            self._abort(handle)
        code = handle.proc.returncode
        return RawRun(exit_code=128 - code if code < 0 else code, stdout=handle.stdout.text(),
                      stderr=handle.stderr.text(), timed_out=timed_out, duration_s=duration,
                      ended_at=time.time())

    def _alive(self, handle: Running) -> bool:
        return handle.proc.poll() is None

    def _abort(self, handle: Running) -> None:
        """Kill the sandbox and return once every process of it is reaped, its cgroup gone.

        The sandbox's PID 1 dies first: the kernel then kills the rest of its PID namespace
        and bwrap, its parent, reaps it and exits. Killing bwrap first would leave PID 1 to
        the host's init, a zombie for seconds after the run.
        """
        _kill_namespace(handle.proc)
        if handle.cgroup is not None:
            handle.cgroup.kill_all()  # anything that got out of the namespace
            handle.cgroup.remove()
        for reader in handle.readers:  # they end once nothing holds the pipes open
            reader.join(timeout=5)

    def _privilege_drop(self) -> list[str]:
        if os.geteuid() != 0:
            return []
        uid = self.settings.sandbox_uid
        return ["setpriv", f"--reuid={uid}", f"--regid={uid}", "--clear-groups",
                "--inh-caps=-all", "--bounding-set=-all", "--no-new-privs"]

    def _rlimits(self, without_cgroup: bool) -> list[str]:
        s = self.settings
        limits = ["prlimit", f"--fsize={s.file_size_limit}", "--core=0", "--nofile=256",
                  "--msgqueue=0",
                  f"--cpu={s.cpu_time_limit_s}"]
        if without_cgroup:  # weaker stand-ins: per-uid process count, address space
            limits += [f"--nproc={s.pids}", f"--as={4 * s.memory_mb * MIB}"]
        return [*limits, "--"]

    def _mounts(self, attempt: Attempt | None) -> list[str]:
        s = self.settings
        args = ["--unshare-all", "--unshare-user", "--disable-userns", "--die-with-parent",
                "--new-session", "--as-pid-1",
                "--cap-drop", "ALL", "--hostname", "sandbox",
                "--ro-bind", "/usr", "/usr", *_system_dir_args(),
                "--ro-bind", str(_venv_root(s.python)), str(_venv_root(s.python)),
                "--proc", "/proc", "--ro-bind", "/proc/sys", "/proc/sys", "--dev", "/dev",
                "--size", str(s.tmpfs_mb * MIB), "--tmpfs", "/tmp",
                "--size", str(s.output_max_bytes), "--tmpfs", OUT_MOUNT,
                "--chdir", "/tmp"]
        if attempt is not None:
            args += ["--ro-bind", str(attempt.job), JOB_MOUNT,
                     "--bind", str(attempt.report), RESULT_MOUNT]
        library = s.library_path()
        if library is not None and library.is_dir():
            args += ["--ro-bind", str(library), LIBRARY_MOUNT]
        # last: every mount point exists now; the root and /dev (and so /dev/shm) become
        # read-only, leaving /tmp and /out, both sized, the only writable places
        return [*args, "--remount-ro", "/dev", "--remount-ro", "/"]


def _system_dir_args() -> list[str]:
    args: list[str] = []
    for name in SYSTEM_DIRS:
        path = Path("/") / name
        if path.is_symlink():
            args += ["--symlink", os.readlink(path), str(path)]
        elif path.is_dir():
            args += ["--ro-bind", str(path), str(path)]
    return args


def _venv_root(python: str) -> Path:
    return Path(python).parent.parent


def _kill_namespace(proc: subprocess.Popen[bytes], reaped_within_s: float = 5.0) -> None:
    """SIGKILL the sandbox's PID 1 (bwrap's child), let bwrap reap it, then reap bwrap."""
    if proc.poll() is not None:
        return  # bwrap exits only after its child, the namespace's PID 1, is reaped
    children = _children(proc.pid)
    for child in children:
        with contextlib.suppress(ProcessLookupError):
            os.kill(child, signal.SIGKILL)
    try:  # no child (yet): bwrap is starting or about to exit on its own
        proc.wait(timeout=reaped_within_s if children else 0.5)
    except subprocess.TimeoutExpired:
        proc.kill()  # bwrap is stuck: the run cgroup's kill takes the rest
        proc.wait()


def _children(pid: int) -> list[int]:
    """The children of ``pid`` (bwrap is single-threaded), [] when it has none or is gone."""
    try:
        listed = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(child) for child in listed.split()]

"""A per-run control group: memory, process and CPU limits for bubblewrap, and a clean kill.

bubblewrap sets no resource limits itself. Both cgroup v1 (one folder per controller, as on
these machines) and v2 (one unified folder) are handled; without write access to the cgroup
tree the bwrap backend falls back to rlimits and says so in ``scenweave sandbox check``.

A run's cgroup is named after the process that made it (``run-<pid>-<start time>-<random>``):
when that process died without cleaning up (killed from outside), :func:`sweep_stale` finds
the cgroup orphaned and removes it, and never touches one whose owner still runs.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import signal
import time
import uuid
from pathlib import Path

from scenweave.sandbox.errors import SandboxError, SandboxUnavailable
from scenweave.sandbox.owner import owner_gone, owner_tag

log = logging.getLogger(__name__)
CPU_PERIOD_US = 100_000
V1_CONTROLLERS = ("memory", "pids", "cpu")
PARENT = "scenweave"  # every run's cgroup is a child of this one
RUN_NAME = re.compile(r"run-(\d+-\d+)-[0-9a-f]+")
REMOVE_WITHIN_S = 5.0  # the kernel may take a moment to let go of killed tasks


class RunCgroup:
    """The cgroup folders of one run; create with :meth:`create`, always :meth:`remove`.

    ``name`` defaults to a new one owned by this process.
    """

    def __init__(self, root: Path, name: str | None = None) -> None:
        self.root = root
        self.unified = _unified(root)
        self.name = name or run_name(os.getpid())
        self.folders = [parent / self.name for parent in _parents(root, self.unified)]

    @staticmethod
    def unavailable_reason(root: Path) -> str | None:
        """Why no per-run cgroup can be made here, or None when it can."""
        for parent in (folder.parent for folder in _parents(root, _unified(root))):
            if not parent.is_dir():
                return f"no cgroup controller at {parent} (SandboxSettings.cgroup_root)"
            if not os.access(parent, os.W_OK):
                return f"{parent} is not writable: run as root or delegate it"
        trial = RunCgroup(root)
        try:
            trial.create(64 * 1024 * 1024, 8, 1.0)
            trial.remove()
        except SandboxError as err:  # e.g. v2 controllers that cannot be enabled here
            return str(err)
        return None

    def create(self, memory_bytes: int, pids: int, cpus: float) -> None:
        """Make the folders and write the limits; SandboxUnavailable on failure."""
        limits = (_v2_limits if self.unified else _v1_limits)(memory_bytes, pids, cpus)
        try:
            if self.unified:
                _enable_v2_controllers(self.root, self.folders[0].parent)
            for folder in self.folders:
                folder.mkdir(parents=True, exist_ok=True)
            for relative, value in limits:
                path = self._path(relative)
                if path.exists():
                    path.write_text(value)
        except OSError as err:
            with contextlib.suppress(SandboxError):
                self.remove()
            raise SandboxUnavailable(f"cannot set up the run cgroup: {err} "
                                     "(SandboxSettings.cgroup_root)") from err

    def procs_files(self) -> list[Path]:
        """The files a process writes its pid into to join this run's cgroups."""
        return [folder / "cgroup.procs" for folder in self.folders]

    def pids(self) -> set[int]:
        """Every process still in the run's cgroups."""
        found: set[int] = set()
        for procs in self.procs_files():
            try:
                found.update(int(line) for line in procs.read_text().split())
            except OSError:
                continue
        return found

    def kill_all(self, grace_s: float = 2.0) -> set[int]:
        """SIGKILL everything in the cgroup until it is empty; return what could not be killed."""
        kill_file = self.folders[0] / "cgroup.kill"
        deadline = time.monotonic() + grace_s
        while (left := self.pids()) and time.monotonic() < deadline:
            if kill_file.exists():
                kill_file.write_text("1")
            else:
                for pid in left:
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(pid, signal.SIGKILL)
            time.sleep(0.01)
        return self.pids()

    def remove(self) -> None:
        """Delete the run's folders (rmdir works once the cgroup is empty); SandboxError
        naming what is left when they are still there after ``REMOVE_WITHIN_S``."""
        deadline = time.monotonic() + REMOVE_WITHIN_S
        for folder in self.folders:
            while not _removed(folder):
                if time.monotonic() > deadline:
                    raise SandboxError(f"cannot remove the run cgroup {folder}: processes "
                                       f"{sorted(self.pids())} are still in it (stuck in the "
                                       "kernel?); a sandbox start after this process ends "
                                       "sweeps it")
                time.sleep(0.01)

    def _path(self, relative: str) -> Path:
        if self.unified:
            return self.folders[0] / relative
        controller, _, name = relative.partition("/")
        return next(f for f in self.folders if f.parts[-3] == controller) / name


def run_name(owner: int) -> str:
    """A new run cgroup's name, owned by the process ``owner``."""
    return f"run-{owner_tag(owner)}-{uuid.uuid4().hex[:8]}"


def orphaned(name: str) -> bool:
    """Whether the process that made the run cgroup ``name`` has ended (False for names of
    other formats: nothing says they are orphaned)."""
    match = RUN_NAME.fullmatch(name)
    return match is not None and owner_gone(match.group(1))


def sweep_stale(root: Path) -> list[str]:
    """Kill and remove the run cgroups whose owning process is dead; return their names."""
    unified = _unified(root)
    names = {folder.name for parent in _parents(root, unified) if parent.is_dir()
             for folder in parent.iterdir() if folder.is_dir()}
    stale = sorted(name for name in names if orphaned(name))
    for name in stale:
        orphan = RunCgroup(root, name)
        orphan.kill_all()
        try:
            orphan.remove()
        except SandboxError as err:  # e.g. a task stuck in the kernel: try again next start
            log.warning("%s", err)
    return stale


def _unified(root: Path) -> bool:
    return (root / "cgroup.controllers").exists()


def _parents(root: Path, unified: bool) -> list[Path]:
    if unified:
        return [root / PARENT]
    return [root / controller / PARENT for controller in V1_CONTROLLERS]


def _removed(folder: Path) -> bool:
    try:
        folder.rmdir()
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return True


def _v1_limits(memory_bytes: int, pids: int, cpus: float) -> list[tuple[str, str]]:
    return [
        ("memory/memory.limit_in_bytes", str(memory_bytes)),
        ("memory/memory.memsw.limit_in_bytes", str(memory_bytes)),  # no swap on top
        ("pids/pids.max", str(pids)),
        ("cpu/cpu.cfs_period_us", str(CPU_PERIOD_US)),
        ("cpu/cpu.cfs_quota_us", str(int(cpus * CPU_PERIOD_US))),
    ]


def _v2_limits(memory_bytes: int, pids: int, cpus: float) -> list[tuple[str, str]]:
    return [
        ("memory.max", str(memory_bytes)),
        ("memory.swap.max", "0"),
        ("pids.max", str(pids)),
        ("cpu.max", f"{int(cpus * CPU_PERIOD_US)} {CPU_PERIOD_US}"),
    ]


def _enable_v2_controllers(root: Path, parent: Path) -> None:
    parent.mkdir(exist_ok=True)
    for folder in (root, parent):
        (folder / "cgroup.subtree_control").write_text("+memory +pids +cpu")

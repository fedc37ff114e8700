"""A per-run control group: memory, process and CPU limits for bubblewrap, and a clean kill.

bubblewrap sets no resource limits itself. Both cgroup v1 (one folder per controller, as on
these machines) and v2 (one unified folder) are handled; without write access to the cgroup
tree the bwrap backend falls back to rlimits and says so in ``scenweave sandbox check``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import time
import uuid
from pathlib import Path

from scenweave.sandbox.errors import SandboxUnavailable

CPU_PERIOD_US = 100_000


class RunCgroup:
    """The cgroup folders of one run; create with :meth:`create`, always :meth:`remove`."""

    def __init__(self, root: Path, memory_bytes: int, pids: int, cpus: float) -> None:
        self.root = root
        self.unified = (root / "cgroup.controllers").exists()
        name = f"run-{uuid.uuid4().hex[:12]}"
        if self.unified:
            self.folders = [root / "scenweave" / name]
        else:
            self.folders = [root / ctl / "scenweave" / name for ctl in ("memory", "pids", "cpu")]
        self.limits = _v2_limits(memory_bytes, pids, cpus) if self.unified else \
            _v1_limits(memory_bytes, pids, cpus)

    @staticmethod
    def unavailable_reason(root: Path) -> str | None:
        """Why no per-run cgroup can be made here, or None when it can."""
        unified = (root / "cgroup.controllers").exists()
        parents = [root] if unified else [root / ctl for ctl in ("memory", "pids", "cpu")]
        for parent in parents:
            if not parent.is_dir():
                return f"no cgroup controller at {parent} (SandboxSettings.cgroup_root)"
            if not os.access(parent, os.W_OK):
                return f"{parent} is not writable: run as root or delegate it"
        trial = RunCgroup(root, 64 * 1024 * 1024, 8, 1.0)
        try:
            trial.create()
        except SandboxUnavailable as err:  # e.g. v2 controllers that cannot be enabled here
            return str(err)
        trial.remove()
        return None

    def create(self) -> None:
        """Make the folders and write the limits; SandboxUnavailable on failure."""
        try:
            if self.unified:
                _enable_v2_controllers(self.root, self.folders[0].parent)
            for folder in self.folders:
                folder.mkdir(parents=True, exist_ok=True)
            for relative, value in self.limits:
                path = self._path(relative)
                if path.exists():
                    path.write_text(value)
        except OSError as err:
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
        """Delete the run's folders, best effort (rmdir works once the cgroup is empty)."""
        for folder in self.folders:
            for _ in range(20):  # the kernel may take a moment to let go of killed tasks
                try:
                    folder.rmdir()
                    break
                except FileNotFoundError:
                    break
                except OSError:
                    time.sleep(0.05)

    def _path(self, relative: str) -> Path:
        if self.unified:
            return self.folders[0] / relative
        controller, _, name = relative.partition("/")
        return next(f for f in self.folders if f.parts[-3] == controller) / name


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

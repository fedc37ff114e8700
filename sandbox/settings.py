"""Sandbox settings: every limit the sandbox enforces is one field here."""

from __future__ import annotations

import importlib.util
import math
import os
from dataclasses import dataclass
from pathlib import Path

BACKENDS = ("docker", "bwrap")
PODMAN_SOCKET = Path("/run/podman/podman.sock")
MIB = 1024 * 1024
#: what a script may leave in the output folder: the scenario (``generate``'s ``out_path``),
#: further scenarios and road networks, and notes or data it wrote for the reader
OUTPUT_NAMES = ("scenario.xosc", "*.xosc", "*.xodr", "*.json", "*.txt", "*.log")


@dataclass(frozen=True)
class SandboxSettings:
    """Limits and locations for running LLM-written scripts; defaults are the safe ones."""

    backend: str = "auto"  # "docker", "bwrap" or "auto"
    wall_time_s: float = 60.0  # hard kill after this
    memory_mb: int = 1024
    pids: int = 64
    cpus: float = 1.0
    output_max_bytes: int = 16 * MIB  # size of the writable output folder
    output_max_files: int = 64
    stdout_max_bytes: int = 64 * 1024  # captured output keeps head and tail, cuts the middle
    stderr_max_bytes: int = 64 * 1024
    tmpfs_mb: int = 16  # the writable /tmp
    image: str = "localhost/scenweave-sandbox:latest"
    docker_host: str | None = None  # default: $DOCKER_HOST, else the podman socket
    python: str = "/opt/scenweave/sandbox-venv/bin/python"  # interpreter bwrap runs
    library_dir: Path | None = None  # default: the installed `scenario_lib` package folder
    sandbox_uid: int = 65534  # uid bwrap drops to when started as root
    cgroup_root: Path = Path("/sys/fs/cgroup")
    work_dir: Path | None = None  # where attempts are staged; default: the system temp folder
    warm_pool: int = 0  # sandboxes started ahead, each still used once (0: every run is cold)
    warm_idle_s: int = 600  # a warm sandbox nobody used by then exits and is replaced
    #: outputs the host takes from the output folder (fnmatch patterns of plain file names,
    #: see ``sandbox.result.name_problem``); any other file is dropped with a warning
    output_names: tuple[str, ...] = OUTPUT_NAMES

    def __post_init__(self) -> None:
        if self.backend not in (*BACKENDS, "auto"):
            raise ValueError(f"SandboxSettings.backend: {self.backend!r} is not one of "
                             f"{', '.join((*BACKENDS, 'auto'))}")
        for name in ("wall_time_s", "memory_mb", "pids", "cpus", "output_max_bytes",
                     "output_max_files", "stdout_max_bytes", "stderr_max_bytes", "tmpfs_mb",
                     "warm_idle_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"SandboxSettings.{name} must be > 0, got {getattr(self, name)!r}")
        if not self.output_names or not all(isinstance(n, str) and n for n in self.output_names):
            raise ValueError("SandboxSettings.output_names must be non-empty patterns, got "
                             f"{self.output_names!r}")
        if self.warm_pool < 0:
            raise ValueError(f"SandboxSettings.warm_pool must be >= 0, got {self.warm_pool!r}")

    @property
    def cpu_time_limit_s(self) -> int:
        """CPU seconds per sandbox: the wall time plus room for a warm sandbox's imports."""
        return math.ceil(self.wall_time_s) + 5

    def engine_url(self) -> str:
        """The container engine to talk to: the setting, ``$DOCKER_HOST``, or podman's socket."""
        if self.docker_host:
            return self.docker_host
        if os.environ.get("DOCKER_HOST"):
            return os.environ["DOCKER_HOST"]
        return f"unix://{PODMAN_SOCKET}"

    def library_path(self) -> Path | None:
        """The folder of the scenario library (``scenweave.scenario_lib``), the scripts'
        only ScenWeave package: mounted read-only into the sandbox."""
        if self.library_dir is not None:
            return Path(self.library_dir)
        # located, not imported: no upward dependency
        spec = importlib.util.find_spec("scenweave.scenario_lib")
        if spec is None or not spec.submodule_search_locations:
            return None
        return Path(next(iter(spec.submodule_search_locations)))

    @property
    def file_size_limit(self) -> int:
        """Largest file the sandbox may write: the result file carries the outputs in base64."""
        return self.output_max_bytes * 4 // 3 + 2 * MIB

"""The Docker backend: one throwaway container per attempt, through the ``docker`` SDK.

Works against Docker or podman's Docker-compatible API. Traps this avoids (measured, see
notes/sandbox.md): podman ignores ``network_disabled`` (``network_mode="none"`` instead),
container logs are unbounded unless ``max-size`` is set, ``read_only`` silently adds writable
unsized ``/tmp``, ``/var/tmp`` and ``/run`` (a sized ``/tmp`` and read-only others here), a
64 MB ``/dev/shm`` comes with the default IPC mode, swap doubles the memory allowance unless
``memswap_limit`` equals ``mem_limit``.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import socket
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass

import docker
import requests
from docker.errors import (
    APIError,
    DockerException,
    NotFound,
    create_api_error_from_http_exception,
)
from docker.models.containers import Container
from docker.types import LogConfig, Ulimit

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
from scenweave.sandbox.capture import CappedBuffer
from scenweave.sandbox.errors import ImageNotFound, SandboxError, SandboxUnavailable
from scenweave.sandbox.owner import owner_gone, owner_tag
from scenweave.sandbox.settings import MIB, SandboxSettings

log = logging.getLogger(__name__)
SANDBOX_PYTHON = "/opt/venv/bin/python"  # where Dockerfile.sandbox installs it
SANDBOX_LABEL = "scenweave.sandbox"
#: ``<host name>/<pid>-<start time>`` of the process that made the container: the next start
#: on that host removes the containers of a process that died (e.g. a warm one it held)
OWNER_LABEL = "scenweave.owner"
PODMAN_API = "v4.0.0"  # podman's own API (for its wait with an interval)
WAIT_INTERVAL = "10ms"
LOG_MAX_SIZE = "1m"
#: RLIMIT_NPROC counts every process of the sandbox uid on the host, across all containers:
#: set to the container's pids_limit, one fork bomb starved every other sandbox. The
#: per-container cap is the pids cgroup (``pids_limit``); this only has to be explicit (podman
#: fails to raise its default here) and far above what concurrent sandboxes hold.
UID_NPROC = 4096
BUILD_HINT = "build it with `bash scripts/setup.d/20-sandbox.sh` or set SandboxSettings.image"


@dataclass
class Running:
    """A started container and the capture of its output."""

    container: Container
    stdout: CappedBuffer
    stderr: CappedBuffer
    reader: threading.Thread | None = None


class DockerSandbox(Sandbox):
    """One container per attempt, removed afterwards, whatever happened."""

    name = "docker"

    def __init__(self, settings: SandboxSettings) -> None:
        super().__init__(settings)
        self._client: docker.DockerClient | None = None

    @property
    def client(self) -> docker.DockerClient:
        """The engine connection, opened on first use."""
        if self._client is None:
            url = self.settings.engine_url()
            try:
                self._client = docker.DockerClient(base_url=url, timeout=30)
                self._client.ping()
            except (DockerException, requests.RequestException) as err:
                self._client = None
                raise SandboxUnavailable(
                    f"no container engine answers at {url}: start one (e.g. `podman system "
                    "service --time=0 unix:///run/podman/podman.sock`) or set "
                    "SandboxSettings.docker_host / DOCKER_HOST") from err
        return self._client

    def probe(self) -> None:
        """Check that the engine answers and the sandbox image exists; remove the containers
        that processes of this host killed from outside left behind."""
        try:
            self.client.images.get(self.settings.image)
        except NotFound as err:
            raise ImageNotFound(f"image {self.settings.image} not found: {BUILD_HINT}") from err
        except (DockerException, requests.RequestException) as err:
            raise SandboxUnavailable(f"container engine error: {err}") from err
        try:
            self._sweep_orphans()
        except (DockerException, requests.RequestException, SandboxError) as err:
            log.warning("could not sweep orphaned sandbox containers (next start will): %s", err)

    def _sweep_orphans(self) -> None:
        host = f"{socket.gethostname()}/"
        # sparse: no inspect per container, which fails when another process removes one
        for container in self.client.containers.list(all=True, sparse=True,
                                                     filters={"label": OWNER_LABEL}):
            owner = (container.attrs.get("Labels") or {}).get(OWNER_LABEL, "")
            if owner.startswith(host) and owner_gone(owner.removeprefix(host)):
                log.warning("removing sandbox container %s: the process that made it is gone",
                            container.short_id)
                _remove(container)

    def _start(self, attempt: Attempt, warm: bool) -> Running:
        s = self.settings
        container = self._create(attempt, warm)
        running = Running(container, CappedBuffer(s.stdout_max_bytes),
                          CappedBuffer(s.stderr_max_bytes))
        try:
            # attached before start, streamed while it runs: the capped engine log keeps only
            # the end of a flood, this keeps head and tail
            stream = container.attach(stdout=True, stderr=True, stream=True, demux=True,
                                      logs=True)
            running.reader = threading.Thread(
                target=_drain, args=(stream, running.stdout, running.stderr), daemon=True,
                name="sandbox-attach")
            container.start()
            running.reader.start()
        except (DockerException, requests.RequestException) as err:
            _remove(container)
            raise SandboxError(f"cannot start the sandbox container: {err}") from err
        return running

    def _finish(self, handle: Running, started: float) -> RawRun:
        try:
            timed_out, code = self._wait(handle.container, started)
            duration = time.monotonic() - started
            if handle.reader is not None:
                handle.reader.join(timeout=10)
        except (DockerException, requests.RequestException) as err:
            raise SandboxError(f"container engine failed during the run: {err}") from err
        finally:
            _remove(handle.container)
        return RawRun(exit_code=code, stdout=handle.stdout.text(), stderr=handle.stderr.text(),
                      timed_out=timed_out, duration_s=duration,
                      ended_at=time.time())

    def _alive(self, handle: Running) -> bool:
        try:
            handle.container.reload()
        except (DockerException, requests.RequestException):
            return False
        return handle.container.status == "running"

    def _abort(self, handle: Running) -> None:
        _remove(handle.container)

    def _wait(self, container: Container, started: float) -> tuple[bool, int | None]:
        remaining = self.settings.wall_time_s - (time.monotonic() - started)
        try:
            return False, self._exit_code(container, max(remaining, 0.1))
        except requests.RequestException:  # the wait timed out: hard kill
            with contextlib.suppress(APIError):  # "not running": it ended meanwhile
                container.kill()
            return True, self._exit_code(container, 30.0)

    def _exit_code(self, container: Container, timeout_s: float) -> int:
        """Wait until ``container`` has exited; requests' timeout error after ``timeout_s``.

        podman's Docker-compatible wait looks every 250 ms, a quarter of a warm attempt;
        its own endpoint takes the interval.
        """
        if not self._podman:
            return int(container.wait(timeout=timeout_s).get("StatusCode", -1))
        api = self.client.api
        response = api.post(f"{api.base_url}/{PODMAN_API}/libpod/containers/{container.id}/wait",
                            params={"condition": "exited", "interval": WAIT_INTERVAL},
                            timeout=timeout_s)
        try:
            response.raise_for_status()
        except requests.HTTPError as err:  # as the SDK's own calls raise it: an APIError
            create_api_error_from_http_exception(err)
        return int(response.json())

    @functools.cached_property
    def _podman(self) -> bool:
        components = self.client.version().get("Components") or []
        return any("podman" in str(c.get("Name", "")).lower() for c in components)

    def _create(self, attempt: Attempt, warm: bool) -> Container:
        s = self.settings
        volumes = {str(attempt.job): {"bind": JOB_MOUNT, "mode": "ro"},
                   str(attempt.report): {"bind": RESULT_MOUNT, "mode": "rw"}}
        library = s.library_path()
        if library is not None and library.is_dir():
            volumes[str(library)] = {"bind": LIBRARY_MOUNT, "mode": "ro"}
        # podman adds writable /var/tmp and /run to a read-only root: mount them read-only
        closed = "ro,size=4k"
        try:
            return self.client.containers.create(
                s.image, command=attempt.harness_command(SANDBOX_PYTHON, warm),
                user=f"{s.sandbox_uid}:{s.sandbox_uid}", network_mode="none", read_only=True,
                mem_limit=s.memory_mb * MIB, memswap_limit=s.memory_mb * MIB,
                pids_limit=s.pids, nano_cpus=int(s.cpus * 1e9), cap_drop=["ALL"],
                security_opt=["no-new-privileges"], environment=SANDBOX_ENV,
                tmpfs={"/tmp": f"size={s.tmpfs_mb}m,mode=1777", "/var/tmp": closed,
                       "/run": closed, OUT_MOUNT: f"size={s.output_max_bytes},mode=1777"},
                ipc_mode="none",  # no /dev/shm (a 64 MB writable tmpfs otherwise)
                ulimits=self._ulimits(), volumes=volumes, working_dir="/tmp",
                hostname="sandbox", labels=owner_labels(),
                log_config=LogConfig(type="json-file", config={"max-size": LOG_MAX_SIZE}),
                stdin_open=False, detach=True)
        except docker.errors.ImageNotFound as err:
            raise ImageNotFound(f"image {s.image} not found: {BUILD_HINT}") from err
        except (DockerException, requests.RequestException) as err:
            raise SandboxError(f"cannot create the sandbox container: {err}") from err

    def _ulimits(self) -> list[Ulimit]:
        s = self.settings
        cpu_s = s.cpu_time_limit_s
        return [Ulimit(name="nofile", soft=256, hard=256),
                Ulimit(name="nproc", soft=UID_NPROC, hard=UID_NPROC),
                Ulimit(name="fsize", soft=s.file_size_limit, hard=s.file_size_limit),
                Ulimit(name="core", soft=0, hard=0),
                Ulimit(name="msgqueue", soft=0, hard=0),  # no POSIX queues in /dev/mqueue
                Ulimit(name="cpu", soft=cpu_s, hard=cpu_s)]

    def close(self) -> None:
        """Stop the warm pool and close the engine connection."""
        super().close()
        if self._client is not None:
            self._client.close()
            self._client = None


def owner_labels(pid: int | None = None) -> dict[str, str]:
    """The labels of a sandbox container made by ``pid`` (default: this process)."""
    return {SANDBOX_LABEL: "attempt", OWNER_LABEL: f"{socket.gethostname()}/{owner_tag(pid)}"}


def _drain(stream: Iterator[tuple[bytes | None, bytes | None]], stdout: CappedBuffer,
           stderr: CappedBuffer) -> None:
    with contextlib.suppress(DockerException, requests.RequestException, OSError):
        for out, err in stream:
            if out:
                stdout.feed(out)
            if err:
                stderr.feed(err)


def _remove(container: Container) -> None:
    try:
        container.remove(force=True)
    except NotFound:
        pass
    except (DockerException, requests.RequestException) as err:
        raise SandboxError(f"could not remove sandbox container {container.short_id}: {err}; "
                           "remove it with `podman rm -f` / `docker rm -f`") from err

"""Starting podman's Docker-compatible API for hosts (and tests) without a Docker daemon."""

from __future__ import annotations

import shutil
import subprocess
import time
from pathlib import Path

import docker
import requests
from docker.errors import DockerException

from scenweave.sandbox.errors import SandboxUnavailable


def engine_answers(url: str) -> bool:
    """True when a Docker-compatible engine answers a ping at ``url``."""
    try:
        client = docker.DockerClient(base_url=url, timeout=5)
        try:
            return bool(client.ping())
        finally:
            client.close()
    except (DockerException, requests.RequestException):
        return False


def start_podman_service(socket: Path,
                         ready_within_s: float = 30.0) -> subprocess.Popen[bytes]:
    """Start ``podman system service`` on ``socket``; the caller stops the returned process.

    It runs in the socket's folder: podman's conmon writes files into the service's working
    folder (an empty ``oom`` when it OOM-kills a container), which must not be the user's.
    """
    if shutil.which("podman") is None:
        raise SandboxUnavailable("podman not found: install the Debian packages podman and runc "
                                 "(scripts/apt-packages.txt)")
    socket.parent.mkdir(parents=True, exist_ok=True)
    url = f"unix://{socket}"
    service = subprocess.Popen(["podman", "system", "service", "--time=0", url],
                               stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, start_new_session=True,
                               cwd=socket.parent)
    deadline = time.monotonic() + ready_within_s
    while time.monotonic() < deadline:
        if service.poll() is not None:
            err = service.communicate()[1].decode(errors="replace").strip()
            raise SandboxUnavailable(f"podman system service exited: {err}")
        if socket.exists() and engine_answers(url):
            return service
        time.sleep(0.1)
    service.kill()
    service.wait()
    raise SandboxUnavailable(f"podman system service did not answer on {url} within "
                             f"{ready_within_s:g} s")

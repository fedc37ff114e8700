"""Real sandboxes for the tests: bubblewrap, and podman's Docker-compatible API for docker.

A backend is skipped only when its engine is not installed here (loudly); when it is
installed but does not work, the tests fail: CI installs both.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from scenweave.sandbox import Sandbox, SandboxSettings, SandboxUnavailable, get_sandbox
from scenweave.sandbox.engine import engine_answers, start_podman_service

#: short limits keep the attack suite quick; the limits themselves are what is under test
FAST = {"wall_time_s": 4.0, "memory_mb": 256, "pids": 32, "output_max_bytes": 1024 * 1024,
        "stdout_max_bytes": 4096, "stderr_max_bytes": 4096}


@pytest.fixture(scope="session")
def engine_url(tmp_path_factory) -> Iterator[str]:
    """A Docker-compatible engine: the configured one, else a podman service of our own."""
    url = SandboxSettings().engine_url()
    if engine_answers(url):
        yield url
        return
    if shutil.which("podman") is None:
        pytest.skip("DOCKER BACKEND NOT TESTED: no engine answers and podman is not installed")
    socket = Path("/run/scenweave-test") / f"podman-{os.getpid()}.sock"
    service = start_podman_service(socket)
    try:
        yield f"unix://{socket}"
    finally:
        service.terminate()
        service.wait(timeout=30)
        socket.unlink(missing_ok=True)


def _settings(backend: str, request, **overrides) -> SandboxSettings:
    if backend == "docker":
        overrides.setdefault("docker_host", request.getfixturevalue("engine_url"))
    elif shutil.which("bwrap") is None:
        pytest.skip("BWRAP BACKEND NOT TESTED: bubblewrap is not installed")
    return SandboxSettings(backend=backend, **{**FAST, **overrides})


def _box_maker(backend: str, request) -> Iterator[Callable[..., Sandbox]]:
    boxes = []

    def make(**overrides) -> Sandbox:
        settings = _settings(backend, request, **overrides)
        try:
            box = get_sandbox(settings)
        except SandboxUnavailable as err:
            pytest.fail(f"{backend} is installed but does not work: {err}")
        boxes.append(box)
        return box

    yield make
    for box in boxes:
        box.close()


@pytest.fixture(params=["bwrap", "docker"])
def make_box(request):
    """Build a working sandbox of the parametrised backend with the given setting overrides."""
    yield from _box_maker(request.param, request)


@pytest.fixture
def make_docker_box(request):
    """``make_box`` for the docker backend only (for evidence only a container engine leaves)."""
    yield from _box_maker("docker", request)


@pytest.fixture
def box(make_box):
    """A sandbox with the quick test limits."""
    return make_box()


@pytest.fixture
def work_dir() -> Iterator[Path]:
    """A staging folder for ``SandboxSettings.work_dir`` that the sandbox uid can reach
    (pytest's own temporary folders are private to root)."""
    folder = Path(tempfile.mkdtemp(prefix="scenweave-test-work-"))
    folder.chmod(0o755)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)

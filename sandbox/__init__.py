"""Running LLM-written scenario scripts in a throwaway sandbox: one interface, two backends.

``get_sandbox(SandboxSettings(backend="docker"|"bwrap"|"auto")).run(code, params, out_dir)``
returns an :class:`ExecResult`; infrastructure failures raise :class:`SandboxError`.
"""

from __future__ import annotations

from scenweave.sandbox.base import Sandbox
from scenweave.sandbox.errors import ImageNotFound, SandboxError, SandboxUnavailable
from scenweave.sandbox.result import ExecResult
from scenweave.sandbox.settings import BACKENDS, SandboxSettings

__all__ = ["ExecResult", "ImageNotFound", "Sandbox", "SandboxError", "SandboxSettings",
           "SandboxUnavailable", "backend_names", "check_backends", "get_sandbox"]


def backend_names() -> tuple[str, ...]:
    """The choices of ``--sandbox``: every backend plus ``auto``."""
    return (*BACKENDS, "auto")


def _make(name: str, settings: SandboxSettings) -> Sandbox:
    if name == "docker":
        from scenweave.sandbox.container import DockerSandbox  # the docker SDK loads only when used

        return DockerSandbox(settings)
    from scenweave.sandbox.bwrap import BwrapSandbox

    return BwrapSandbox(settings)


def check_backends(settings: SandboxSettings | None = None) -> dict[str, str | None]:
    """Each backend's name -> None when it works here, else the reason it does not."""
    settings = settings or SandboxSettings()
    reasons: dict[str, str | None] = {}
    for name in BACKENDS:
        try:
            _probed(_make(name, settings)).close()
            reasons[name] = None
        except SandboxError as err:
            reasons[name] = str(err)
    return reasons


def get_sandbox(settings: SandboxSettings | None = None) -> Sandbox:
    """The sandbox of ``settings.backend``, checked to work; ``auto`` prefers a container
    engine that answers and has the image, else bubblewrap. Close it when done (it may hold
    a warm pool and an engine connection); it is also a context manager.

    Raises :class:`SandboxUnavailable` naming the setting to change when it cannot run.
    """
    settings = settings or SandboxSettings()
    box = _first_working(settings)
    box.start_pool()
    return box


def _first_working(settings: SandboxSettings) -> Sandbox:
    if settings.backend != "auto":
        return _probed(_make(settings.backend, settings))
    reasons = []
    for name in BACKENDS:
        try:
            return _probed(_make(name, settings))
        except SandboxUnavailable as err:
            reasons.append(f"{name}: {err}")
    raise SandboxUnavailable("no sandbox backend works here: " + "; ".join(reasons))


def _probed(box: Sandbox) -> Sandbox:
    try:
        box.probe()
    except SandboxError:
        box.close()
        raise
    return box

"""Infrastructure failures of the sandbox: one root exception, messages name what to change.

A failing *script* is never an exception: it is an :class:`sandbox.ExecResult` value.
"""

from __future__ import annotations

from scenweave.errors import InfrastructureError


class SandboxError(InfrastructureError):
    """Root of every sandbox infrastructure failure (engine down, image missing, ...)."""


class SandboxUnavailable(SandboxError):
    """The chosen backend cannot run on this host; the message says which setting to change."""


class ImageNotFound(SandboxUnavailable):
    """The container engine answers but the sandbox image is not built."""

"""The one sandbox interface: stage an attempt, let a backend execute it, read the outcome."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from scenweave.sandbox.attempt import Attempt, RawRun, params_to_json
from scenweave.sandbox.pool import WarmPool
from scenweave.sandbox.result import ExecResult
from scenweave.sandbox.settings import SandboxSettings


class Sandbox(ABC):
    """Runs LLM-written scripts, one throwaway sandbox per attempt.

    With ``SandboxSettings.warm_pool > 0`` that many sandboxes are started ahead (the
    interpreter up, scenariogeneration imported) and each still serves one attempt only.
    """

    name = ""

    def __init__(self, settings: SandboxSettings) -> None:
        self.settings = settings
        self._pool: WarmPool | None = None

    def start_pool(self) -> None:
        """Start the warm pool of ``settings.warm_pool`` sandboxes (no-op when 0)."""
        if self.settings.warm_pool > 0 and self._pool is None:
            self._pool = WarmPool(self, self.settings.warm_pool)

    @property
    def warm_ready(self) -> int:
        """How many warm sandboxes wait for an attempt (0 without a pool)."""
        return self._pool.ready if self._pool is not None else 0

    def run(self, code: str, params: Mapping[str, Any], out_dir: Path) -> ExecResult:
        """Run ``code``'s ``generate(params, <out_dir>/scenario.xosc)`` in a fresh sandbox.

        The script's failures (exceptions, timeout, limits) come back in the result; only
        infrastructure failures raise :class:`sandbox.SandboxError`.
        """
        began_at = time.time()
        params_json = params_to_json(params)
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        slot = self._pool.take() if self._pool is not None else None
        attempt, handle = slot if slot is not None else (Attempt(self.settings), None)
        try:
            attempt.load(code, params_json)
            started = time.monotonic()
            if handle is None:
                handle = self._start(attempt, warm=False)
            else:
                attempt.go()
        except BaseException:
            if handle is not None:
                self._abort(handle)
            attempt.close()
            raise
        try:
            raw = self._finish(handle, started)
            return attempt.outcome(raw, out_dir, self.name, began_at)
        finally:
            attempt.close()

    @abstractmethod
    def probe(self) -> None:
        """Raise :class:`sandbox.SandboxUnavailable` saying why this backend cannot run here."""

    @abstractmethod
    def _start(self, attempt: Attempt, warm: bool) -> Any:
        """Start the harness of ``attempt`` under every limit; return a handle on it."""

    @abstractmethod
    def _finish(self, handle: Any, started: float) -> RawRun:
        """Wait until the wall-time limit counted from ``started``, kill, clean up, report."""

    @abstractmethod
    def _alive(self, handle: Any) -> bool:
        """Whether a started (warm) sandbox is still waiting for its job."""

    @abstractmethod
    def _abort(self, handle: Any) -> None:
        """Kill and remove a started sandbox that will not be used."""

    def close(self) -> None:
        """Stop the warm pool; backends also release their engine connection."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None

    def __enter__(self) -> Sandbox:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

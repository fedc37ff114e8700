"""A pool of pre-started (warm) sandboxes: each waits for one job and is then replaced.

A warm sandbox has its interpreter up and scenariogeneration imported, so an attempt only
pays for loading the job. It still serves exactly one attempt: isolation between attempts
is the same as cold.
"""

from __future__ import annotations

import logging
import threading
from typing import Any, Protocol

from scenweave.sandbox.attempt import Attempt
from scenweave.sandbox.settings import SandboxSettings

log = logging.getLogger(__name__)
Slot = tuple[Attempt, Any]


class Starter(Protocol):
    """What the pool needs of a sandbox backend (``sandbox.base.Sandbox`` is one)."""

    name: str
    settings: SandboxSettings

    def _start(self, attempt: Attempt, warm: bool) -> Any: ...

    def _alive(self, handle: Any) -> bool: ...

    def _abort(self, handle: Any) -> None: ...


class WarmPool:
    """Keeps ``size`` warm sandboxes of ``box`` ready, refilling in the background."""

    def __init__(self, box: Starter, size: int) -> None:
        self._box = box
        self._size = size
        self._ready: list[Slot] = []
        self._starting = 0
        self._closed = False
        self._starters: list[threading.Thread] = []
        self._lock = threading.Lock()
        self._refill()

    @property
    def ready(self) -> int:
        """How many warm sandboxes are started and waiting (some may have idled out)."""
        with self._lock:
            return len(self._ready)

    def take(self) -> Slot | None:
        """A live warm sandbox, or None (the caller then starts a cold one)."""
        taken, dead = None, []
        with self._lock:
            while self._ready and taken is None:
                slot = self._ready.pop(0)
                if self._box._alive(slot[1]):
                    taken = slot
                else:
                    dead.append(slot)  # e.g. idle past warm_idle_s
        for slot in dead:
            self._discard(slot)
        self._refill()
        return taken

    def close(self) -> None:
        """Kill and remove every waiting sandbox, after the ones still starting are up."""
        with self._lock:
            self._closed = True
            starters, self._starters = self._starters, []
        for starter in starters:  # each discards its own sandbox once it sees the pool closed
            starter.join(timeout=60)
        with self._lock:
            slots, self._ready = self._ready, []
        for slot in slots:
            self._discard(slot)

    def _refill(self) -> None:
        with self._lock:  # registered under the lock, so close() joins every starter
            if self._closed:
                return
            missing = self._size - len(self._ready) - self._starting
            self._starting += max(missing, 0)
            self._starters = [t for t in self._starters if t.is_alive()]
            for _ in range(missing):
                starter = threading.Thread(target=self._start_one, daemon=True,
                                           name="sandbox-warm")
                self._starters.append(starter)
                starter.start()

    def _start_one(self) -> None:
        attempt = Attempt(self._box.settings)
        try:
            handle = self._box._start(attempt, warm=True)
        except Exception as err:  # noqa: BLE001 - a cold start will report it to the caller
            log.warning("warm %s sandbox failed to start: %s", self._box.name, err)
            attempt.close()
            with self._lock:
                self._starting -= 1
            return
        with self._lock:
            self._starting -= 1
            keep = not self._closed
            if keep:
                self._ready.append((attempt, handle))
        if not keep:
            self._discard((attempt, handle))

    def _discard(self, slot: Slot) -> None:
        attempt, handle = slot
        try:
            self._box._abort(handle)
        finally:
            attempt.close()

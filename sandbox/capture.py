"""Bounded capture of a sandbox's stdout/stderr: keep the head and the tail, cut the middle."""

from __future__ import annotations

import threading
from collections import deque
from typing import IO


class CappedBuffer:
    """Accumulates bytes up to ``cap``: the first half and the last half survive a flood."""

    def __init__(self, cap: int) -> None:
        self.head_cap = cap // 2
        self.tail_cap = cap - self.head_cap
        self.head = bytearray()
        self.tail: deque[bytes] = deque()
        self.tail_len = 0
        self.total = 0

    def feed(self, data: bytes) -> None:
        """Add a chunk; whatever falls between head and tail is only counted."""
        self.total += len(data)
        room = self.head_cap - len(self.head)
        if room > 0:
            self.head += data[:room]
            data = data[room:]
        if not data:
            return
        self.tail.append(data[-self.tail_cap:])
        self.tail_len += len(self.tail[-1])
        while self.tail_len - len(self.tail[0]) >= self.tail_cap:
            self.tail_len -= len(self.tail.popleft())

    def text(self) -> str:
        """The kept bytes as text, with a marker saying how much of the middle was cut."""
        tail = b"".join(self.tail)[-self.tail_cap:] if self.tail else b""
        cut = self.total - len(self.head) - len(tail)
        marker = f"\n[... {cut} bytes cut by the sandbox ...]\n".encode() if cut else b""
        return (bytes(self.head) + marker + tail).decode("utf-8", errors="replace")


def drain_in_background(stream: IO[bytes], buffer: CappedBuffer) -> threading.Thread:
    """Read ``stream`` to its end into ``buffer`` on a daemon thread (so a flood never blocks).

    ``stream`` must be unbuffered (``Popen(bufsize=0)``).
    """

    def drain() -> None:
        with stream:
            while chunk := stream.read(65536):  # unbuffered pipe: returns what is there
                buffer.feed(chunk)

    thread = threading.Thread(target=drain, daemon=True, name="sandbox-capture")
    thread.start()
    return thread

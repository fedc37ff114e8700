"""Host-side evidence for the attack tests: listeners, processes, canaries."""

from __future__ import annotations

import os
import select
import socket
import uuid
from pathlib import Path


def marker() -> str:
    """A unique string an attack puts into the processes it leaves behind."""
    return f"scenweave-attack-{uuid.uuid4().hex}"


def processes_with(text: str) -> list[int]:
    """Host pids whose command line contains ``text``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if text.encode() in cmdline and int(entry.name) != os.getpid():
            found.append(int(entry.name))
    return found


class Listener:
    """A TCP and a UDP socket on every host address (loopback included) that record arrivals."""

    def __init__(self, udp_port: int = 0) -> None:
        self.tcp = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.tcp.bind(("0.0.0.0", 0))
        self.tcp.listen(8)
        self.tcp.setblocking(False)
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("0.0.0.0", udp_port))
        self.udp.setblocking(False)

    @property
    def tcp_port(self) -> int:
        return self.tcp.getsockname()[1]

    @property
    def udp_port(self) -> int:
        return self.udp.getsockname()[1]

    def received(self, wait_s: float = 0.5) -> list[str]:
        """Everything that reached the listener: connections and datagrams."""
        events = []
        readable, _, _ = select.select([self.tcp, self.udp], [], [], wait_s)
        if self.tcp in readable:
            connection, peer = self.tcp.accept()
            events.append(f"tcp connection from {peer}")
            connection.close()
        if self.udp in readable:
            data, peer = self.udp.recvfrom(65536)
            events.append(f"udp {data[:40]!r} from {peer}")
        return events

    def close(self) -> None:
        self.tcp.close()
        self.udp.close()

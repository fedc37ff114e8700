"""Ending the real processes a test or benchmark started (workers, submitters)."""

from __future__ import annotations

import signal
import subprocess
from collections.abc import Iterable


def stop_processes(processes: Iterable[subprocess.Popen[str]], grace_s: float = 20.0) -> None:
    """SIGTERM every process still running (RQ: warm shutdown), then SIGKILL those that have
    not ended within ``grace_s``."""
    processes = list(processes)
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
    for process in processes:
        try:
            process.wait(timeout=grace_s)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()

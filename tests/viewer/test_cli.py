"""``scenweave view RUN_DIR --port N`` as a user starts it: a process serving on loopback."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_view_serves_the_runs_on_loopback_until_stopped(viewer_runs):
    port = free_port()
    scenweave = Path(sys.executable).with_name("scenweave")
    server = subprocess.Popen([str(scenweave), "view", str(viewer_runs["runs"]), "--port",
                               str(port)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True)
    try:
        url = f"http://127.0.0.1:{port}/"
        assert server.stdout.readline().strip() == f"view: {url} (Ctrl-C to stop)"
        deadline, runs = time.monotonic() + 30, None
        while runs is None and time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(url + "api/runs", timeout=5) as answer:
                    runs = json.loads(answer.read())
            except OSError:
                time.sleep(0.2)
        assert runs is not None, "the viewer did not answer"
        assert [len(run["scenarios"]) for run in runs] == [2]
    finally:
        server.terminate()
        server.wait(timeout=20)

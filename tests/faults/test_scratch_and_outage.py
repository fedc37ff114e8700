"""Scratch folders named after their owner are swept once the owner is dead, never before;
waiting for Redis says so once, carries on when it is back and gives up after its budget."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import pytest

from scenweave.player.scratch import owned_folder, sweep_dead
from scenweave.queue.connection import QueueError, connect, riding_out
from scenweave.testing.redis_server import RedisServer


def test_a_dead_owners_folder_is_swept_and_a_live_ones_kept(tmp_path):
    child = subprocess.Popen([sys.executable, "-c",
                              "from pathlib import Path; import sys, time; "
                              "from scenweave.player.scratch import owned_folder; "
                              "print(owned_folder(Path(sys.argv[1]), 'esmini'), flush=True); "
                              "time.sleep(60)", str(tmp_path)],
                             stdout=subprocess.PIPE, text=True)
    theirs = tmp_path / child.stdout.readline().strip()
    try:
        mine = owned_folder(tmp_path, "maps")
        (tmp_path / "not-ours").mkdir()
        assert sweep_dead(tmp_path) == []  # the child still runs
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
        assert sweep_dead(tmp_path) == [theirs]
        assert mine.is_dir() and (tmp_path / "not-ours").is_dir()
    finally:
        child.kill()
        child.wait()


@pytest.mark.skipif(shutil.which("redis-server") is None, reason="redis-server is not installed")
def test_a_call_rides_out_an_outage_and_gives_up_after_its_budget(tmp_path):
    server = RedisServer(tmp_path / "redis").start()
    said: list[str] = []
    try:
        connection = connect(server.url)
        connection.set("k", "v")
        server.kill()
        restart = threading.Timer(1.0, server.start)
        restart.start()
        assert riding_out(lambda: connection.set("k", "w"), connection, 30, said.append)
        restart.join()
        assert connection.get("k") == b"w"
        where = f"the job queue at 127.0.0.1:{server.port}"
        assert len(said) == 2, said  # once that it waits, once that it is back
        assert said[0].startswith(f"{where} does not answer") and "waiting up to 30 s" in said[0]
        assert said[1].startswith(f"{where} is back after")
        server.kill()
        started = time.monotonic()
        with pytest.raises(QueueError, match="did not come back within 1 s"):
            riding_out(lambda: connection.get("k"), connection, 1.0, said.append)
        assert time.monotonic() - started < 5
    finally:
        server.stop()

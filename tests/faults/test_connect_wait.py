"""A worker's connection (``connect(url, wait=True)``) waits for a Redis that is not up yet,
within its budget and saying so once; other commands' connections fail at once."""

from __future__ import annotations

import time

import pytest

from scenweave.queue.connection import OUTAGE_ENV, QueueError, connect
from scenweave.testing.redis_server import free_port


def test_a_waiting_connection_gives_up_after_its_budget_saying_so_once(monkeypatch, capsys):
    monkeypatch.setenv(OUTAGE_ENV, "1")
    url = f"redis://127.0.0.1:{free_port()}/0"
    started = time.monotonic()
    with pytest.raises(QueueError, match="did not come back within 1 s"):
        connect(url, wait=True)
    assert 0.9 <= time.monotonic() - started < 5
    said = capsys.readouterr().err
    assert said.count("does not answer") == 1 and "waiting up to 1 s" in said


def test_a_connection_that_does_not_wait_fails_at_once(monkeypatch, capsys):
    monkeypatch.setenv(OUTAGE_ENV, "60")
    started = time.monotonic()
    with pytest.raises(QueueError, match="cannot reach the job queue"):
        connect(f"redis://127.0.0.1:{free_port()}/0")
    assert time.monotonic() - started < 2
    assert "does not answer" not in capsys.readouterr().err

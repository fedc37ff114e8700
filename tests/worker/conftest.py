"""Fixtures of the worker tests: a real redis-server, canonical sample records, worker
processes started as ``scenweave worker`` subprocesses."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from scenweave.testing.processes import stop_processes
from scenweave.testing.redis_server import RedisServer
from tests.worker.gates import GATES_ENV
from tests.worker.records import ingest_with_poisoned_record

GATED_MATCHER = "tests.worker.gates:GatedMatcher"
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def redis_server(tmp_path_factory):
    server = RedisServer(tmp_path_factory.mktemp("redis")).start()
    yield server
    server.stop()


@pytest.fixture
def redis_url(redis_server):
    """The URL of an emptied Redis database for one test."""
    from redis import Redis

    Redis.from_url(redis_server.url).flushall()
    return redis_server.url


@pytest.fixture(scope="module")
def records(sample_raw, tmp_path_factory) -> Path:
    """Canonical records of the sample data; BRAKE row 1 asks for a gap no spawn fits."""
    return ingest_with_poisoned_record(sample_raw, tmp_path_factory.mktemp("records"))


@pytest.fixture
def gates(tmp_path) -> Path:
    path = tmp_path / "gates"
    path.mkdir()
    return path


class Workers:
    """``scenweave worker`` processes of one test, stopped at its end."""

    def __init__(self, url: str, gates: Path, cwd: Path):
        self.url, self.gates, self.cwd = url, gates, cwd
        self.processes: list[subprocess.Popen] = []

    def start(self, *extra: str) -> subprocess.Popen:
        env = {**os.environ, GATES_ENV: str(self.gates), "PYTHONPATH": str(REPO)}
        process = subprocess.Popen(
            [sys.executable, "-m", "scenweave.cli", "worker", "--queue", self.url,
             "--preload", GATED_MATCHER, "--heartbeat", "1", "--maintenance-interval", "1",
             *extra], cwd=self.cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True)
        self.processes.append(process)
        return process

    def stop(self) -> None:
        stop_processes(self.processes)


@pytest.fixture
def workers(redis_url, gates, tmp_path):
    started = Workers(redis_url, gates, tmp_path)
    yield started
    started.stop()

"""Machines that share nothing but the queue: two ``scenweave worker`` processes, each in its
own mount namespace with the submitter's folder hidden under an empty tmpfs (as another host
would be), a real password-protected ``redis-server`` on loopback, and ``submit --wait`` at the
submitter. The run folder must end as a local ``scenweave run`` of the same records leaves it,
file for file and byte for byte (measured times and who ran it aside)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.queue.collector import collect
from scenweave.queue.connection import QueueError, connect, redacted
from scenweave.testing.redis_server import RedisServer
from tests.worker.conftest import REPO

PASSWORD = "s3cret-queue"
CLASSES = "BRAKE,LCF,U4_1,CINF"
#: what differs between two makings of the same scenario: clocks and who made it
MEASURED = {"timings_s", "t_s", "worker", "submission"}


def _can_hide_folders() -> str | None:
    if os.geteuid() != 0:
        return "needs root for unshare -m and a tmpfs mount"
    if shutil.which("unshare") is None:
        return "unshare (util-linux) is not installed"
    probe = subprocess.run(["unshare", "-m", "mount", "-t", "tmpfs", "none", "/mnt"],
                           capture_output=True, text=True)
    return None if probe.returncode == 0 else f"unshare -m cannot mount: {probe.stderr.strip()}"


@pytest.fixture(scope="module")
def locked_redis(tmp_path_factory):
    """A redis-server that answers only with ``PASSWORD``; yields its URL with the password."""
    server = RedisServer(tmp_path_factory.mktemp("redis-auth")).start()
    from redis import Redis

    Redis.from_url(server.url).config_set("requirepass", PASSWORD)
    yield server.url.replace("redis://", f"redis://:{PASSWORD}@")
    server.stop()


def test_a_queue_with_a_password_needs_it_and_never_shows_it(locked_redis):
    without = locked_redis.replace(f":{PASSWORD}@", "")
    with pytest.raises(QueueError, match="refused the login .* needs its password in the URL"):
        connect(without)
    with pytest.raises(QueueError, match="refused the login") as wrong:
        connect(locked_redis.replace(PASSWORD, "wrong"))
    assert "wrong" not in str(wrong.value) and ":***@127.0.0.1" in str(wrong.value)
    assert connect(locked_redis).ping()
    assert PASSWORD not in redacted(locked_redis)


def _normalised(value: object) -> object:
    if isinstance(value, dict):
        return {k: _normalised(v) for k, v in value.items() if k not in MEASURED}
    if isinstance(value, list):
        return [_normalised(v) for v in value]
    return value


def _content(path: Path) -> object:
    """A file as compared: bytes, except the outcome, the playback and the trace, which say
    how long each step took."""
    if path.name in ("status.json", "replay.json"):
        return _normalised(json.loads(path.read_text()))
    if path.name == "trace.jsonl":
        return [_normalised(json.loads(line)) for line in path.read_text().splitlines()]
    return path.read_bytes()


def _scenario_files(run: Path) -> dict[str, object]:
    return {p.relative_to(run).as_posix(): _content(p) for p in sorted(run.rglob("*"))
            if p.is_file() and not p.relative_to(run).parts[0].startswith(".")
            and len(p.relative_to(run).parts) > 1}


def _hidden_worker(url: str, hidden: Path, scratch: Path, log: Path) -> subprocess.Popen:
    """``scenweave worker`` in its own mount namespace where ``hidden`` is an empty tmpfs;
    it refuses to start if it can still see anything there."""
    script = ('mount -t tmpfs -o size=1m scenweave-hidden "$1" && '
              'test -z "$(ls -A "$1")" && shift && exec "$@"')
    return subprocess.Popen(
        ["unshare", "-m", "--propagation", "private", "sh", "-c", script, "sh", str(hidden),
         sys.executable, "-m", "scenweave.cli", "worker", "--queue", url, "--scratch",
         str(scratch), "--heartbeat", "2", "--maintenance-interval", "2"],
        cwd=scratch, env={**os.environ, "PYTHONPATH": str(REPO)},
        stdout=log.open("w"), stderr=subprocess.STDOUT)


def test_workers_that_cannot_see_the_submitter_fill_its_run_folder_as_a_local_run(
        sample_raw, locked_redis, tmp_path, esmini):
    problem = _can_hide_folders()
    if problem:
        pytest.skip(f"SHARED-NOTHING QUEUE NOT TESTED: {problem}")
    submitter = tmp_path / "submitter"
    records = submitter / "records"
    ingested = CliRunner().invoke(cli, ["ingest", str(sample_raw), "--out", str(records)])
    assert ingested.exit_code == 0, ingested.output
    local = CliRunner().invoke(cli, ["run", str(records), "--no-llm", "--out",
                                     str(tmp_path / "local"), "--run-id", "r1",
                                     "--classes", CLASSES])
    assert local.exit_code == 0, local.output

    workers = []
    for i in (1, 2):
        (tmp_path / f"host{i}").mkdir()
        workers.append(_hidden_worker(locked_redis, submitter, tmp_path / f"host{i}",
                                      tmp_path / f"host{i}.log"))
    try:
        submitted = CliRunner().invoke(cli, [
            "submit", str(records), "--no-llm", "--out", str(submitter / "runs"),
            "--run-id", "r1", "--classes", CLASSES, "--queue", locked_redis,
            "--wait", "--timeout", "300"])
    finally:
        for worker in workers:
            worker.send_signal(signal.SIGTERM)
        for worker in workers:
            worker.wait(timeout=60)
    logs = "\n".join((tmp_path / f"host{i}.log").read_text() for i in (1, 2))
    assert submitted.exit_code == 0, submitted.output + logs
    run = submitter / "runs" / "r1"
    summary = json.loads((run / "summary.json").read_text())
    assert summary["total"] == json.loads((run / "run.json").read_text())["scenarios"] == 11
    assert len({o["worker"] for o in summary["scenarios"]}) == 2, "both hosts made scenarios"
    assert "11 of 11 scenarios finished" in (run / "report.html").read_text()

    queued, here = _scenario_files(run), _scenario_files(tmp_path / "local" / "r1")
    assert sorted(queued) == sorted(here)
    assert any(name.endswith("replay.svg") for name in here)  # drawn by the workers too
    differing = [name for name in here if queued[name] != here[name]]
    assert not differing, f"{len(differing)} files differ from the local run: {differing[:5]}"
    local_summary = json.loads((tmp_path / "local" / "r1" / "summary.json").read_text())
    for key in ("counts", "by_class", "error_taxonomy", "replay"):
        assert summary[key] == local_summary[key], key
    assert not any((run / ".staging").iterdir())
    for i in (1, 2):  # each host's scratch is left empty: every folder went back
        assert [p.name for p in (tmp_path / f"host{i}").iterdir()] == []

    again = collect(run, connect(locked_redis))  # collecting again writes nothing twice
    assert again.committed == [] and again.summary["total"] == 11

"""The queue end to end: a real redis-server, real ``scenweave worker`` processes, real
sample records and the real Town04 matcher behind test-controlled gates."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.inputs import InputSelection
from scenweave.pipeline import is_infrastructure_error
from scenweave.queue.collector import collect
from scenweave.queue.connection import QueueError, connect
from scenweave.run_folder import safe_name
from scenweave.testing.redis_server import free_port
from tests.replies import right_replies
from tests.worker.conftest import GATED_MATCHER
from tests.worker.records import BRAKE, LCF, POISONED


def submit(records: Path, runs: Path, url: str, *extra: str) -> str:
    result = CliRunner().invoke(cli, ["submit", str(records), "--no-llm", "--out", str(runs),
                                      "--queue", url, "--matcher", GATED_MATCHER, *extra])
    assert result.exit_code == 0, result.output
    return result.output.strip().splitlines()[-1]


def wait_for(condition, timeout_s: float = 90, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def outcome(run: Path, scenario_id: str) -> dict | None:
    path = run / safe_name(scenario_id) / "status.json"
    return json.loads(path.read_text()) if path.exists() else None


def attempts(gates: Path, scenario_id: str) -> list[str]:
    path = gates / f"attempts-{safe_name(scenario_id)}"
    return path.read_text().split() if path.exists() else []


def finished(run: Path, url: str) -> int:
    """How many scenarios are in the run folder after collecting what the workers handed back
    (the workers never see the run folder)."""
    collect(run, connect(url))
    return len(list(run.glob("*/status.json")))


def assert_made_past_spawn(result: dict) -> None:
    assert result["spawn_id"] is not None, result["error"]
    assert result["status"] == "ok", result["error"]


def test_two_workers_share_a_batch_and_a_poisoned_record_fails_alone(records, tmp_path, gates,
                                                                       workers, redis_url):
    run = tmp_path / "runs" / "shared"
    (gates / f"block-{LCF[0]}").touch()
    line = submit(records, tmp_path / "runs", redis_url, "--run-id", "shared",
                  "--classes", "BRAKE,LCF,U4_1")
    assert line.startswith("run shared: 8 scenarios enqueued, 0 already done")
    first = workers.start()
    wait_for(lambda: (gates / f"started-{LCF[0]}").exists(), what="worker 1 to block on LCF 0")
    second = workers.start("--burst")
    assert second.wait(timeout=120) == 0, second.stdout.read()
    assert finished(run, redis_url) == 7  # everything but the blocked scenario, done by worker 2
    (gates / "release").touch()
    wait_for(lambda: finished(run, redis_url) == 8, what="the blocked scenario")
    wait_for(lambda: (run / "report.html").exists(), what="the report of the finished run")

    summary = json.loads((run / "summary.json").read_text())
    assert summary["total"] == 8
    assert len({o["worker"] for o in summary["scenarios"]}) == 2
    poisoned = outcome(run, POISONED)
    assert poisoned["status"] == "failed" and poisoned["error_taxonomy"] == ["spawn"]
    assert "NoSpawnFits" in poisoned["error"] and "m needed" in poisoned["error"]
    for other in summary["scenarios"]:
        if other["scenario_id"] != POISONED:
            assert_made_past_spawn(other)
    assert all(len(attempts(gates, o["scenario_id"])) == 1 for o in summary["scenarios"])
    assert "8 of 8 scenarios finished" in (run / "report.html").read_text()
    assert first.poll() is None  # the non-burst worker keeps waiting for work


def test_a_worker_killed_mid_job_leaves_its_scenario_to_another_exactly_once(
        records, tmp_path, gates, workers, redis_url):
    run = tmp_path / "runs" / "killed"
    (gates / f"block-{BRAKE[0]}").touch()
    submit(records, tmp_path / "runs", redis_url, "--run-id", "killed", "--classes", "BRAKE",
           "--retry-delays", "1")
    doomed = workers.start()
    wait_for(lambda: (gates / f"started-{BRAKE[0]}").exists(), what="the job to start")
    horse = int((gates / f"started-{BRAKE[0]}").read_text())
    os.kill(doomed.pid, signal.SIGKILL)
    doomed.wait(timeout=10)
    wait_for(lambda: not _alive(horse), timeout_s=10, what="the work horse to die with it")
    (gates / "release").touch()

    workers.start()
    wait_for(lambda: finished(run, redis_url) == 3, timeout_s=120,
             what="the abandoned job to be redone")
    assert len(attempts(gates, BRAKE[0])) == 2  # the killed attempt and the retry
    folders = [p for p in run.iterdir() if p.name.startswith(safe_name(BRAKE[0]))]
    assert len(folders) == 1
    trace = [json.loads(line) for line in (folders[0] / "trace.jsonl").read_text().splitlines()]
    assert [e["node"] for e in trace].count("spawn") == 1  # nothing of the killed attempt
    assert_made_past_spawn(outcome(run, BRAKE[0]))
    assert not any((run / ".staging").iterdir())
    wait_for(lambda: json.loads((run / "summary.json").read_text())["total"] == 3,
             what="the summary")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return stat.exists() and stat.read_text().split()[2] != "Z"


def test_infrastructure_errors_are_retried_and_scenario_errors_are_not(records, tmp_path, gates,
                                                                       workers, redis_url):
    run = tmp_path / "runs" / "retries"
    (gates / f"infra-{BRAKE[0]}").write_text("1")  # the LLM server is down once
    (gates / f"infra-{LCF[1]}").write_text("99")  # ... and for good
    (gates / f"bad-{LCF[0]}").touch()
    submit(records, tmp_path / "runs", redis_url, "--run-id", "retries", "--classes",
           "BRAKE,LCF", "--retries", "2", "--retry-delays", "0")
    assert workers.start("--burst").wait(timeout=120) == 0
    assert finished(run, redis_url) == 6

    assert len(attempts(gates, BRAKE[0])) == 2
    assert_made_past_spawn(outcome(run, BRAKE[0]))
    bad = outcome(run, LCF[0])
    assert len(attempts(gates, LCF[0])) == 1
    assert bad["status"] == "failed" and bad["error"].startswith("ValueError")
    down = outcome(run, LCF[1])
    assert len(attempts(gates, LCF[1])) == 3  # first try + 2 retries
    assert down["status"] == "failed" and down["error_taxonomy"] == ["infrastructure"]
    assert "ConnectionError" in down["error"] and "--retry-failed" in down["error"]
    assert (run / "report.html").exists()


def test_resubmitting_never_enqueues_a_scenario_twice(records, tmp_path, gates, workers,
                                                      redis_url):
    runs, run = tmp_path / "runs", tmp_path / "runs" / "again"
    args = ("--run-id", "again", "--classes", "BRAKE")
    assert submit(records, runs, redis_url, *args).startswith(
        "run again: 3 scenarios enqueued, 0 already done, 0 already queued")
    assert submit(records, runs, redis_url, *args).startswith(
        "run again: 0 scenarios enqueued, 0 already done, 3 already queued")
    assert workers.start("--burst").wait(timeout=120) == 0
    assert submit(records, runs, redis_url, *args).startswith(
        "run again: 0 scenarios enqueued, 3 already done")
    for path in (run / safe_name(BRAKE[2])).iterdir():
        path.unlink()
    (run / safe_name(BRAKE[2])).rmdir()
    assert submit(records, runs, redis_url, *args).startswith("run again: 1 scenarios enqueued")
    assert workers.start("--burst").wait(timeout=120) == 0
    assert finished(run, redis_url) == 3
    failed = json.loads((run / "summary.json").read_text())["counts"]["failed"]
    assert failed >= 1  # the poisoned record
    assert submit(records, runs, redis_url, *args, "--retry-failed").startswith(
        f"run again: {failed} scenarios enqueued")


def test_an_unreachable_queue_is_one_error_naming_the_setting():
    with pytest.raises(QueueError, match="--queue / set SCENWEAVE_QUEUE"):
        connect(f"redis://127.0.0.1:{free_port()}/0")


@pytest.mark.parametrize("error, infrastructure", [
    (ConnectionError("connection refused"), True),
    (OSError(28, "No space left on device"), True),
    (TimeoutError("read timed out"), True),
    (MemoryError(), True),
    (ValueError("bad params"), False),
    (KeyError("ego_speed_ms"), False),
    (SyntaxError("invalid syntax"), False),
])
def test_infrastructure_errors_are_told_from_scenario_errors(error, infrastructure):
    assert is_infrastructure_error(error) is infrastructure


def test_sandbox_and_queue_errors_are_infrastructure_spawn_errors_are_not():
    from scenweave.sandbox import SandboxUnavailable
    from scenweave.spawn_db.errors import NoSpawnFits

    assert is_infrastructure_error(SandboxUnavailable("no engine"))
    assert is_infrastructure_error(QueueError("the queue is gone"))
    assert not is_infrastructure_error(NoSpawnFits("no spawn fits"))


def test_the_agent_runs_in_the_workers(records, tmp_path, gates, workers, redis_url):
    """The agent path through the queue: settings travel with the job, the LLM is replayed,
    each scenario's trace and checkpoints land in its folder."""
    import shutil

    if shutil.which("bwrap") is None:
        pytest.skip("AGENT IN WORKER NOT TESTED: bubblewrap is not installed")
    right = right_replies(records, InputSelection(classes=("BRAKE", "U4_1")))
    replies = tmp_path / "replies.json"
    replies.write_text(json.dumps({**{sid: [reply] for sid, reply in right.items()},
                                   BRAKE[0]: ["no code here", right[BRAKE[0]]]}))
    result = CliRunner().invoke(cli, [
        "submit", str(records), "--out", str(tmp_path / "runs"), "--queue", redis_url,
        "--matcher", GATED_MATCHER, "--run-id", "agent", "--classes", "BRAKE,U4_1",
        "--llm", "replay", "--replay-file", str(replies), "--repair", "error-feedback",
        "--sandbox", "bwrap"])
    assert result.exit_code == 0, result.output
    assert workers.start("--burst").wait(timeout=180) == 0
    run = tmp_path / "runs" / "agent"
    assert finished(run, redis_url) == 5
    summary = json.loads((run / "summary.json").read_text())
    statuses = {o["scenario_id"]: o["status"] for o in summary["scenarios"]}
    assert statuses.pop(BRAKE[0]) == "repaired"
    assert statuses.pop(POISONED) == "failed"
    assert set(statuses.values()) == {"ok"} and len(statuses) == 3
    brake = outcome(run, BRAKE[0])
    assert brake["llm"] == {"backend": "replay", "model": "replay"}
    assert brake["repair"] == "error_feedback"
    folder = run / safe_name(BRAKE[0])
    nodes = [json.loads(line)["node"] for line in (folder / "trace.jsonl").read_text().splitlines()]
    assert nodes == ["spawn", "retrieve", "generate", "execute", "repair", "execute", "validate"]
    assert (folder / "checkpoints.sqlite").is_file()

"""The warm pool: sandboxes started ahead, each still used for one attempt only."""

from __future__ import annotations

import shutil
import time

import pytest

from scenweave.agent.run import close_shared, shared_sandbox
from scenweave.commands.agent_options import pipeline_settings
from tests.sandbox.evidence import processes_with

PROBE = """
import os, sys
def generate(params, out_path):
    seen = os.path.exists("/tmp/previous-attempt")
    open("/tmp/previous-attempt", "w").write("x")
    warm = "scenariogeneration" in sys.modules
    open(out_path, "w").write(f"{seen} {warm}")
"""
IDLE_S = 4321  # unique in the warm harnesses' command lines


def _warm_harnesses(idle_s: int = IDLE_S) -> list[int]:
    return processes_with(f"--warm\0{idle_s}")


def _wait_for_a_warm_one(box, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while box.warm_ready == 0:
        assert time.monotonic() < deadline, "the warm pool started no sandbox in 60 s"
        time.sleep(0.1)


def test_each_attempt_gets_a_fresh_warm_sandbox(make_box, tmp_path):
    box = make_box(warm_pool=1, warm_idle_s=IDLE_S)
    outputs = []
    for index in range(3):
        _wait_for_a_warm_one(box)  # let the pool refill so the attempt finds a warm sandbox
        result = box.run(PROBE, {}, tmp_path / str(index))
        assert result.ok, result
        outputs.append((tmp_path / str(index) / "scenario.xosc").read_text())
    assert outputs == ["False True"] * 3  # warm (imports done), never shared
    box.close()
    assert _warm_harnesses() == []


def test_wall_time_counts_from_the_job_not_from_the_warm_start(make_box, tmp_path):
    box = make_box(warm_pool=1, warm_idle_s=IDLE_S, wall_time_s=2.0)
    time.sleep(3)  # longer than the wall time: a warm sandbox waiting is not running a job
    result = box.run("import time\ndef generate(p, o):\n    time.sleep(0.5)\n", {}, tmp_path)
    assert result.ok, result
    slow = box.run("import time\ndef generate(p, o):\n    time.sleep(60)\n", {}, tmp_path)
    assert slow.timed_out and slow.duration_s < 2.0 + 3.0


def test_an_idle_warm_sandbox_expires_and_runs_still_work(make_box, tmp_path):
    box = make_box(warm_pool=1, warm_idle_s=1)
    time.sleep(3)  # the warm one gave up waiting
    result = box.run(PROBE, {}, tmp_path)
    assert result.ok, result
    assert (tmp_path / "scenario.xosc").read_text().startswith("False")


def test_a_batch_runs_its_attempts_in_warm_sandboxes(tmp_path):
    """What ``scenweave run`` / the worker use: the agent's shared sandbox keeps a warm one."""
    if shutil.which("bwrap") is None:
        pytest.skip("BWRAP BACKEND NOT TESTED: bubblewrap is not installed")
    settings = pipeline_settings(no_llm=False, top_n=1, llm="replay",
                                 replay_file=tmp_path / "replies.json", sandbox="bwrap",
                                 replay=False).agent
    close_shared()  # an earlier test's shared sandbox may hold a warm one idled out by now
    try:
        box = shared_sandbox(settings)
        _wait_for_a_warm_one(box)  # the LLM's turn: the pool starts a sandbox meanwhile
        result = box.run(PROBE, {}, tmp_path)
        assert result.ok, result
        assert (tmp_path / "scenario.xosc").read_text() == "False True"
        assert result.timings["import"] < 0.05, result.timings
    finally:
        close_shared()
    assert _warm_harnesses(settings.sandbox.warm_idle_s) == []

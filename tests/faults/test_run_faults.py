"""Faults of a real ``scenweave run`` and a real worker (``scenweave.testing.run_faults``):
SIGKILL mid-batch then ``--resume``, a full disk (a small tmpfs) then the step its error line
names, esmini crashing mid-replay, a worker started before its Redis. Each asserts every
scenario exactly once, whole (no half-written file), and the exit codes the outcome calls for.
"""

from __future__ import annotations

import re
import shutil

import pytest

from scenweave.testing.faults import FaultBench
from scenweave.testing.run_faults import (
    disk_full,
    esmini_crashed,
    mount_problem,
    run_killed,
    worker_before_redis,
)


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> FaultBench:
    return FaultBench.make(tmp_path_factory.mktemp("run-faults"), per_class=2)


def assert_each_once_and_whole(delivery) -> None:
    assert delivery.expected == 8
    assert (delivery.once, delivery.lost, delivery.doubled) == (8, 0, 0), delivery.output
    assert delivery.damaged == [], delivery.output


def test_a_run_killed_mid_batch_is_resumed_by_resume(bench, esmini):
    killed = run_killed(bench, after=2)
    assert_each_once_and_whole(killed)
    assert killed.not_ok == [], killed.output
    assert killed.exit_codes == [-9, 0], killed.output
    kept = re.search(r"kept after the kill: (\d+) whole, 0 half-written", killed.output)
    assert kept and 2 <= int(kept.group(1)) < 8, killed.output
    assert " resumed in " in killed.output and "already done" in killed.output


@pytest.mark.skipif(mount_problem() is not None, reason=f"no tmpfs to fill: {mount_problem()}")
def test_a_full_disk_stops_in_one_line_and_the_step_it_names_finishes(bench, esmini):
    full = disk_full(bench)
    assert_each_once_and_whole(full)
    assert full.not_ok == [], full.output
    assert full.exit_codes == [1, 0], full.output
    [line] = [line for line in full.output.splitlines() if line.startswith("error:")]
    assert "No space left on device" in line
    assert "run full stopped: the disk holding " in line and "small-disk/full is full" in line
    assert line.endswith("free some space, then run the same command with --run-id full to "
                         "resume")
    assert "0 half-written" in full.output.splitlines()[0]  # nothing torn when it stopped


def test_an_esmini_crash_mid_replay_fails_one_scenario_and_the_batch_goes_on(bench, esmini):
    crashed, outcome = esmini_crashed(bench)
    assert_each_once_and_whole(crashed)
    assert crashed.exit_codes == [1], crashed.output  # a scenario failed: exit 1
    assert crashed.not_ok == [outcome["scenario_id"]], crashed.output
    [finding] = outcome["validation"]["errors"]
    assert finding["code"] == "REPLAY_ENGINE"
    assert finding["message"].startswith("esmini could not play the scenario: esmini crashed")
    assert "SIGSEGV" in finding["message"]
    assert "7 ok" in crashed.output and "1 failed" in crashed.output


@pytest.mark.skipif(shutil.which("redis-server") is None, reason="redis-server is not installed")
def test_a_worker_started_before_its_redis_waits_for_it(bench):
    late = worker_before_redis(bench, down_s=3.0)
    assert_each_once_and_whole(late)
    assert late.exit_codes == [0], late.output
    assert "worker still waiting 3 s after saying so: True" in late.output
    assert late.output.count("does not answer") == 1, late.output  # said once
    assert "waiting up to 60 s" in late.output and "is back after" in late.output

"""The queue's faults with real processes (``scenweave.testing.faults``): a real
``redis-server`` SIGKILLed and restarted under two ``scenweave worker`` and a ``scenweave
submit --wait``, with its append-only file and without, and a worker SIGKILLed mid-job. Every
scenario reaches the run folder exactly once and complete, and each command ends with the
exit code its outcome calls for."""

from __future__ import annotations

import shutil

import pytest

from scenweave.testing.faults import FaultBench, redis_restart, worker_killed

pytestmark = pytest.mark.skipif(shutil.which("redis-server") is None,
                                reason="redis-server is not installed")


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> FaultBench:
    return FaultBench.make(tmp_path_factory.mktemp("faults"), per_class=2)


def assert_each_once_and_ok(delivery) -> None:
    assert delivery.expected == 8
    assert (delivery.once, delivery.lost, delivery.doubled) == (8, 0, 0), delivery.output
    assert delivery.not_ok == [], delivery.output


def test_a_redis_restarted_with_its_append_only_file_is_waited_out(bench):
    delivery = redis_restart(bench, appendonly=True)
    assert_each_once_and_ok(delivery)
    assert delivery.exit_codes == [0], delivery.output  # nobody gave up, nothing to do by hand
    assert delivery.output.count("does not answer") == 1  # said once, by the submitter
    assert "is back after" in delivery.output
    assert "ended by itself" not in delivery.output  # no worker exits because Redis blinked


def test_a_redis_restarted_empty_names_the_lost_and_one_resubmit_finishes(bench):
    delivery = redis_restart(bench, appendonly=False)
    assert_each_once_and_ok(delivery)
    assert delivery.exit_codes == [1, 0], delivery.output
    assert "no longer in the queue (submit the same --run-id again)" in delivery.output
    assert "ended by itself" not in delivery.output


def test_a_worker_killed_mid_job_takes_its_scheduler_and_leaves_no_scratch(bench):
    killed = worker_killed(bench)
    assert_each_once_and_ok(killed.delivery)
    assert killed.delivery.exit_codes == [0]
    assert len(killed.scheduler_pids) == 1
    assert killed.schedulers_alive_after_kill == []
    assert killed.scratch_after_kill  # the kill left its folder behind ...
    assert killed.scratch_after_next_start == []  # ... which the next start swept

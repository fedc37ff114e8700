"""Worker processes: RQ workers on the ScenWeave queue, warm, on any machine.

Workers share nothing with the submitter but the queue (``submit``): each job makes its
scenario in the worker's own scratch folder and hands the folder back (``job``). A worker that
dies mid-job (SIGKILL, OOM, host reboot) stops heartbeating; another worker's maintenance
finds the abandoned job in the StartedJobRegistry and retries it.
"""

from __future__ import annotations

import ctypes
import importlib
import multiprocessing
import os
import signal
import sys
import tempfile
import threading
from contextlib import suppress
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, cast

from scenweave.pipeline import PipelineSettings
from scenweave.queue.connection import QUEUE_NAME, connect, riding_out, wait_for_queue
from scenweave.queue.job import scratch_root, use_scratch_root
from scenweave.runner import make_scenario
from scenweave.schemas.params import Params
from scenweave.spawn_db.registry import DEFAULT_MATCHER, matcher_for

#: reference scripts whose worked examples a worker makes once before work (``warm_up``)
WARM_UP_SCRIPTS = ("gen_hw_lcf.py", "gen_ur_stop_at_tfl_red.py")


@dataclass
class WorkerOptions:
    """How a worker process behaves; the defaults suit a GPU host serving long LLM jobs."""

    burst: bool = False
    heartbeat_s: int = 30
    maintenance_interval_s: int = 60
    preload_matcher: str | None = DEFAULT_MATCHER
    #: the map whose matcher is preloaded (a bundled town or an .xodr path; None: Town04)
    preload_map: str | None = None
    #: imported once before work (and before ``--workers N`` forks), not on the first job
    preload_modules: tuple[str, ...] = ("scenweave.corpus", "scenweave.scenario_lib.builder",
                                       "scenweave.schemas", "scenweave.agent",
                                       "scenweave.presentation.replay_figures")
    #: the worker's own folder for scenarios in the making (None: a temp folder)
    scratch: Path | None = None
    #: make a highway and an urban example once before work (``warm_up``)
    warm_up: bool = True


class RidesOutRedis:
    """The steps of RQ's work loop that would end a worker when Redis goes away (the loop
    quits on any error outside its dequeue), each waiting for Redis and carrying on instead;
    mixed in before RQ's worker class, whose methods it wraps."""

    connection: Any

    def execute_beating(self, job: Any, queue: Any) -> None:
        raise NotImplementedError  # the worker's: run the job, heartbeat and all

    def riding_out_job(self, job: Any, queue: Any) -> None:
        """Run the job; when RQ's own bookkeeping of it meets a Redis outage, wait. The job's
        hand-back, if made, is in Redis already (run_job waits it out); the job, left
        started, is found abandoned and retried, and its retry sees it handed back."""
        from redis.exceptions import ConnectionError as RedisConnectionError
        from redis.exceptions import TimeoutError as RedisTimeoutError

        try:
            self.execute_beating(job, queue)
        except (RedisConnectionError, RedisTimeoutError) as err:
            wait_for_queue(self.connection, err)

    def run_maintenance_tasks(self) -> None:
        riding_out(super().run_maintenance_tasks, self.connection)  # type: ignore[misc]

    def check_for_suspension(self, burst: bool) -> None:
        riding_out(partial(super().check_for_suspension, burst),  # type: ignore[misc]
                   self.connection)

    def heartbeat(self, timeout: int | None = None, pipeline: Any = None) -> Any:
        if pipeline is not None:  # queued in the caller's pipeline: no call to Redis yet
            return super().heartbeat(timeout, pipeline)  # type: ignore[misc]
        return riding_out(partial(super().heartbeat, timeout),  # type: ignore[misc]
                          self.connection)


def make_worker(connection: Any, options: WorkerOptions) -> Any:
    """An RQ worker on the ScenWeave queue that runs each job in its own process, warm, and
    whose abandoned jobs are found quickly.

    RQ's default worker forks a fresh work horse per job, which throws away every cache a
    scenario fills (spawn lanes, XSD, the player's server and road graph, matplotlib's fonts):
    1.7 s instead of 0.3 s per scenario, measured. This one is RQ's ``SimpleWorker`` (the job
    runs in the worker, which dies with it: nothing outlives a killed worker to race the
    retry) with a heartbeat thread, so a job's registry entry still lives only two heartbeats
    plus 10 s; an idle worker wakes every maintenance interval to look for abandoned jobs
    (RQ's default is every 10 minutes). Redis going away is waited out (``riding_out``) in
    every step of RQ's work loop that would otherwise end the worker; RQ's own dequeue already
    retries with a backoff.
    """
    from rq import SimpleWorker
    from rq.worker import WorkerStatus

    class ScenWeaveWorker(RidesOutRedis, SimpleWorker):
        _beating: tuple[threading.Event, threading.Thread] | None = None

        def get_heartbeat_ttl(self, job: Any, working_time: float = 0.0) -> int:
            return 2 * self.job_monitoring_interval + 10

        def execute_job(self, job: Any, queue: Any) -> None:
            self.riding_out_job(job, queue)
            self.set_state(WorkerStatus.IDLE)

        def execute_beating(self, job: Any, queue: Any) -> None:
            execution = self.prepare_execution(job)
            stop = threading.Event()
            beat = threading.Thread(target=self._beat, args=(job, execution, stop),
                                    name="scenweave-heartbeat", daemon=True)
            self._beating = (stop, beat)
            beat.start()
            try:
                self.perform_job(job, queue, execution)
            finally:
                self._stop_beating()

        def _beat(self, job: Any, execution: Any, stop: threading.Event) -> None:
            while not stop.wait(self.job_monitoring_interval):
                with suppress(Exception):  # a missed beat is what the TTL is for
                    self.maintain_heartbeats(job, execution)

        def _stop_beating(self) -> None:
            if self._beating:
                stop, beat = self._beating
                stop.set()
                beat.join()
                self._beating = None

        def handle_job_success(self, *args: Any, **kwargs: Any) -> Any:
            self._stop_beating()  # no beat after the job's end is written
            return super().handle_job_success(*args, **kwargs)

        def handle_job_failure(self, *args: Any, **kwargs: Any) -> Any:
            self._stop_beating()
            return super().handle_job_failure(*args, **kwargs)

    return ScenWeaveWorker([QUEUE_NAME], connection=connection,
                           job_monitoring_interval=options.heartbeat_s,
                           maintenance_interval=options.maintenance_interval_s,
                           worker_ttl=options.maintenance_interval_s + 15)


def preload(options: WorkerOptions) -> None:
    """Load the matcher and the pipeline's modules now (``--workers N`` forks inherit them),
    and settle the scratch folder scenarios are made in."""
    if options.scratch is not None:
        use_scratch_root(options.scratch)
    scratch_root()
    if options.warm_up:
        warm_up(options)


def warm_up(options: WorkerOptions) -> None:
    """Make the worked examples of ``WARM_UP_SCRIPTS`` once, replay and figure included, and
    throw them away, so the first job finds what they loaded (the matcher's lanes, the XSD,
    the player's road graph, matplotlib and its fonts) and ``--workers N`` forks inherit it.
    A failure here is no failure of the worker: the jobs will say what is wrong."""
    from scenweave.corpus.worked_example import CORPUS_DIR, example_params
    from scenweave.player import ReplaySettings

    settings = PipelineSettings(no_llm=True, replay=ReplaySettings(), map=options.preload_map)
    with tempfile.TemporaryDirectory(prefix="scenweave-warm-up-") as tmp:
        for script in WARM_UP_SCRIPTS:
            with suppress(Exception):
                matcher = matcher_for(options.preload_matcher or DEFAULT_MATCHER,
                                      options.preload_map)
                # a name of its own: the example's own id may be a record's of a real run
                params = cast(Params, {**(example_params(CORPUS_DIR / script) or {}),
                                       "scenario_id": f"scenweave-warm-up-{Path(script).stem}"})
                folder = Path(tmp) / script
                folder.mkdir()
                make_scenario(params, 0, folder, settings, matcher)
    for module in options.preload_modules:
        # an optional part (e.g. the agent) not installed: the jobs needing it will say so
        with suppress(ImportError):
            importlib.import_module(module)
    if options.preload_matcher:
        matcher_for(options.preload_matcher, options.preload_map)


def work(url: str | None, options: WorkerOptions) -> bool:
    """Run one worker in this process until stopped (or the queue is empty with ``burst``);
    a Redis not up yet is waited for (bounded, said once), as an outage is."""
    connection = connect(url, wait=True)
    preload(options)
    children_die_with_this_process()
    return make_worker(connection, options).work(burst=options.burst, with_scheduler=True)


def work_in_processes(url: str | None, options: WorkerOptions, count: int) -> int:
    """Run ``count`` workers, each in its own process; return how many exited cleanly."""
    connect(url, wait=True)  # wait (or fail) here, once, with the clear message
    preload(options)
    children_die_with_this_process()
    context = multiprocessing.get_context("fork")
    processes = [context.Process(target=work, args=(url, options), name=f"scenweave-worker-{i}")
                 for i in range(count)]
    for process in processes:
        process.start()
    previous = signal.signal(signal.SIGTERM, lambda *_: _stop(processes))
    try:
        for process in processes:
            process.join()
    finally:
        signal.signal(signal.SIGTERM, previous)
    return sum(p.exitcode == 0 for p in processes)


def _stop(processes: list[Any]) -> None:
    for process in processes:
        if process.is_alive():
            os.kill(process.pid, signal.SIGTERM)  # RQ: warm shutdown after the current job


#: prctl's option that has the kernel signal a process when its parent ends (linux/prctl.h)
PR_SET_PDEATHSIG = 1
_forking_parent = [0]
_lifeline_tied = [False]


def children_die_with_this_process() -> None:
    """Every process forked from here on (RQ's scheduler, ``--workers N``'s workers) gets
    SIGTERM when this process ends, however it ends: a SIGKILLed worker leaves no scheduler
    behind to hold the scheduler's lock and enqueue jobs for a worker that is gone. Linux
    only (elsewhere nothing changes); programs started with ``subprocess`` are not forks of
    this kind and are left alone."""
    if sys.platform != "linux" or _lifeline_tied[0]:
        return
    libc = ctypes.CDLL(None, use_errno=True)
    os.register_at_fork(before=lambda: _forking_parent.__setitem__(0, os.getpid()),
                        after_in_child=lambda: _tie_to_parent(libc))
    _lifeline_tied[0] = True


def _tie_to_parent(libc: Any) -> None:
    libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    if os.getppid() != _forking_parent[0]:  # the parent died before the tie was made
        os.kill(os.getpid(), signal.SIGTERM)

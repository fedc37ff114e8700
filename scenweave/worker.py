"""The queue on the GPU host: a run's scenarios as RQ jobs on Redis, done by worker processes.

``submit`` loads the input, opens the run folder and enqueues one job per scenario, job id =
run id + scenario id, so nothing runs twice: a scenario with a ``status.json`` or a job still
queued/running is not enqueued again (and RQ's ``unique`` enqueue makes two racing submits
safe). A worker runs ``process_scenario`` in RQ's forked work horse, commits the scenario
folder atomically and rewrites the run's ``summary.json``; the job that finishes the run also
writes ``report.html``.

Retries are for infrastructure only: ``process_scenario`` turns every problem of a scenario
into a ``failed`` outcome and raises only infrastructure errors (LLM server down, sandbox
engine gone, disk full), which RQ retries with the delays of ``JobOptions``. A worker that
dies mid-job (SIGKILL, OOM, host reboot) stops heartbeating; another worker's maintenance
finds the abandoned job in the StartedJobRegistry and retries it. When the retries run out,
the scenario is committed as ``failed`` with taxonomy ``infrastructure``, so the run still
completes and ``submit --retry-failed`` picks it up again.
"""

from __future__ import annotations

import fcntl
import importlib
import json
import multiprocessing
import os
import signal
import sys
import uuid
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenweave.inputs import InputSelection, load_input
from scenweave.pipeline import PipelineSettings, base_outcome, process_scenario
from scenweave.progress import progress
from scenweave.report import write_run_report
from scenweave.run_folder import RUN_FILE, SUMMARY_FILE, RunFolder, safe_name
from scenweave.runner import round_robin, run_description, summarize

QUEUE_NAME = "scenweave"
QUEUE_ENV = "SCENWEAVE_QUEUE"
DEFAULT_QUEUE_URL = "redis://127.0.0.1:6379/0"
#: ``module:callable`` making a job's spawn matcher, called with the map's name (None: Town04)
DEFAULT_MATCHER = "scenweave.runner:default_matcher"
LOCK_FILE = ".summary.lock"
#: RQ job states in which a job will still run: such a job is not enqueued a second time
PENDING_STATES = ("queued", "started", "scheduled", "deferred")


class QueueError(Exception):
    """Root of the queue's infrastructure failures (Redis unreachable, ...)."""


@dataclass
class JobOptions:
    """How each scenario job is queued."""

    retries: int = 3
    retry_delays_s: tuple[int, ...] = (10, 60, 300)
    timeout_s: int = 3600
    result_ttl_s: int = 7 * 86400
    matcher: str = DEFAULT_MATCHER


@dataclass
class WorkerOptions:
    """How a worker process behaves; the defaults suit a GPU host serving long LLM jobs."""

    burst: bool = False
    heartbeat_s: int = 30
    maintenance_interval_s: int = 60
    preload_matcher: str | None = DEFAULT_MATCHER
    #: the map whose matcher is preloaded (a bundled town or an .xodr path; None: Town04)
    preload_map: str | None = None
    #: imported once in the worker so each forked work horse starts warm (~1 s per job saved)
    preload_modules: tuple[str, ...] = ("scenweave.corpus", "scenweave.corpus.corpus_utils",
                                       "scenweave.schemas", "scenweave.agent")


@dataclass
class SubmitResult:
    """What ``submit`` did."""

    folder: RunFolder
    enqueued: list[str] = field(default_factory=list)
    already_done: int = 0
    already_queued: int = 0
    input_issues: list[dict] = field(default_factory=list)
    submission: str = field(default_factory=lambda: uuid.uuid4().hex)

    def line(self) -> str:
        """The one-line summary printed at the end of ``scenweave submit``."""
        issues = f", {len(self.input_issues)} input issues" if self.input_issues else ""
        return (f"run {self.folder.run_id}: {len(self.enqueued)} scenarios enqueued, "
                f"{self.already_done} already done, {self.already_queued} already queued"
                f"{issues} -> {self.folder.root}")


def queue_url(url: str | None = None) -> str:
    """The Redis URL to use: ``url``, else ``$SCENWEAVE_QUEUE``, else the local default."""
    return url or os.environ.get(QUEUE_ENV) or DEFAULT_QUEUE_URL


def connect(url: str | None = None) -> Any:
    """A checked connection to the Redis of ``url``; QueueError names the setting to change."""
    from redis import Redis
    from redis.exceptions import RedisError

    url = queue_url(url)
    try:
        connection = Redis.from_url(url)
        connection.ping()
    except (RedisError, ValueError) as err:
        raise QueueError(f"cannot reach the job queue at {url}: {err}; start redis-server there "
                         f"or pass --queue / set {QUEUE_ENV}") from err
    return connection


def job_id(run_id: str, scenario_id: str) -> str:
    """The RQ job id of a scenario of a run (RQ allows letters, digits, ``_`` and ``-``)."""
    return safe_name(f"{run_id}--{scenario_id}").replace(".", "_")


def submit(data: Path, out_root: Path, selection: InputSelection, settings: PipelineSettings,
           connection: Any, run_id: str | None = None, retry_failed: bool = False,
           options: JobOptions | None = None) -> SubmitResult:
    """Enqueue every selected record of ``data`` not done or queued yet, into one run folder."""
    from redis.exceptions import RedisError

    options = options or JobOptions()
    loaded = load_input(Path(data), selection)
    folder = RunFolder.open(out_root, run_id)
    result = SubmitResult(folder, input_issues=[i.to_dict() for i in loaded.report.issues])
    description = run_description(data, loaded, selection, settings, folder)
    folder.write(RUN_FILE, {**description, "queue": True, "input_issues": result.input_issues})
    try:
        queue = _queue(connection)
        for index, params in progress(round_robin(loaded.params), desc="enqueue",
                                      total=len(loaded.params)):
            _submit_one(queue, folder, params, index, settings, retry_failed, options, result)
    except RedisError as err:
        raise QueueError(f"the job queue failed while enqueueing run {folder.run_id}: {err}; "
                         "check the Redis server, then submit the same --run-id again") from err
    if not result.enqueued:
        refresh_run(folder.root)
    return result


def _submit_one(queue: Any, folder: RunFolder, params: dict, index: int,
                settings: PipelineSettings, retry_failed: bool, options: JobOptions,
                result: SubmitResult) -> None:
    from rq import Callback, Retry
    from rq.exceptions import DuplicateJobError, NoSuchJobError
    from rq.job import Job

    scenario_id = params["scenario_id"]
    done = folder.outcome(scenario_id)
    if done and not (retry_failed and done.get("status") == "failed"):
        result.already_done += 1
        return
    jid = job_id(folder.run_id, scenario_id)
    try:
        old = Job.fetch(jid, connection=queue.connection)
        if old.get_status() in PENDING_STATES:
            result.already_queued += 1
            return
        old.delete()
    except NoSuchJobError:
        pass
    spec = {"run_dir": str(folder.root.resolve()), "params": params, "index": index,
            "settings": settings, "matcher": options.matcher, "submission": result.submission}
    retry = Retry(max=options.retries, interval=list(options.retry_delays_s) or 0) \
        if options.retries else None
    try:
        queue.enqueue_call(run_job, args=(spec,), job_id=jid, unique=True, retry=retry,
                           timeout=options.timeout_s, result_ttl=options.result_ttl_s,
                           failure_ttl=options.result_ttl_s, on_failure=Callback(on_job_failure),
                           description=f"{folder.run_id}: {scenario_id}")
    except DuplicateJobError:
        result.already_queued += 1
        return
    result.enqueued.append(jid)


def _queue(connection: Any) -> Any:
    from rq import Queue

    return Queue(QUEUE_NAME, connection=connection)


# --- the job -------------------------------------------------------------------------------

_matchers: dict[tuple[str, str | None], Any] = {}


def matcher_for(factory: str, map_name: str | None = None) -> Any:
    """The spawn matcher ``module:callable`` makes for ``map_name``, made once per process."""
    from scenweave.spawn_db import DEFAULT_MAP

    key = (factory, map_name or DEFAULT_MAP)
    if key not in _matchers:
        module, _, name = factory.partition(":")
        _matchers[key] = getattr(importlib.import_module(module), name)(map_name)
    return _matchers[key]


def run_job(spec: dict) -> str:
    """RQ job: make one scenario into its run folder and update the run; return its status.

    Idempotent: a scenario already committed (e.g. a retry after the worker died between
    the commit and telling Redis) is not made again.
    """
    folder = RunFolder(Path(spec["run_dir"]))
    scenario_id = spec["params"]["scenario_id"]
    done = folder.outcome(scenario_id)
    if done is None or _redo(done, spec):
        # the scenario's staging folder is emptied first: leftovers of a dead attempt go
        staging = folder.staging(scenario_id)
        settings = spec["settings"]
        matcher = matcher_for(spec.get("matcher") or DEFAULT_MATCHER,
                              getattr(settings, "map", None))
        try:
            outcome = process_scenario(spec["params"], spec["index"], staging, settings, matcher)
        finally:
            _close_agent()
        outcome.update(worker=os.environ.get("RQ_WORKER_ID"), submission=spec.get("submission"))
        folder.commit(scenario_id, staging, outcome)
        done = outcome
    refresh_run(folder.root)
    return done["status"]


def _close_agent() -> None:
    """Close the agent's LLM and sandbox (its warm pool) made for this job: RQ's work horse
    ends with ``os._exit``, which skips ``atexit``, and a warm sandbox must not outlive it."""
    agent_run = sys.modules.get("scenweave.agent.run")
    if agent_run is not None:
        agent_run.close_shared()


def _redo(done: dict, spec: dict) -> bool:
    # submit --retry-failed enqueues a failed scenario again: that submission redoes it,
    # while a retry of the job that already committed it does not
    return done.get("status") == "failed" and done.get("submission") != spec.get("submission")


def on_job_failure(job: Any, connection: Any, exc_type: type, exc_value: BaseException,
                   traceback: Any) -> None:
    """RQ failure callback: once a job has no retries left, commit the scenario as failed."""
    if job.retries_left:
        return
    spec = job.args[0]
    folder = RunFolder(Path(spec["run_dir"]))
    scenario_id = spec["params"]["scenario_id"]
    if folder.outcome(scenario_id):
        return
    reason = str(exc_value) or "the worker died while running this scenario"
    outcome = {**base_outcome(spec["params"]), "error_taxonomy": ["infrastructure"],
               "error": f"{exc_type.__name__}: {reason} (no retries left; fix the "
                        "infrastructure, then submit again with --retry-failed)",
               "submission": spec.get("submission")}
    folder.commit(scenario_id, folder.staging(scenario_id), outcome)
    refresh_run(folder.root)


# --- the run's summary and report ----------------------------------------------------------

@contextmanager
def _run_lock(run_dir: Path) -> Iterator[None]:
    with open(run_dir / LOCK_FILE, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def refresh_run(run_dir: Path) -> dict:
    """Rewrite the run's ``summary.json``; write ``report.html`` once every scenario is done.

    Workers finishing at the same time take turns (a lock file in the run folder), so the
    last one to write has seen every committed scenario.
    """
    folder = RunFolder(Path(run_dir))
    with _run_lock(folder.root):
        run = _read_json(folder.root / RUN_FILE)
        issues = run.get("input_issues", _read_json(folder.root / SUMMARY_FILE).get("input_issues"))
        summary = summarize(folder, issues or [])
        folder.write(SUMMARY_FILE, summary)
        if summary["total"] >= int(run.get("scenarios") or 0):
            write_run_report(folder.root)
    return summary


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return {}


# --- worker processes ----------------------------------------------------------------------

def make_worker(connection: Any, options: WorkerOptions) -> Any:
    """An RQ worker on the ScenWeave queue whose abandoned jobs are found quickly.

    RQ lets a started job's registry entry live ``heartbeat + 60`` s; here it is two
    heartbeats plus 10 s, and an idle worker wakes every maintenance interval to look for
    abandoned jobs (RQ's default is every 10 minutes).
    """
    from rq import Worker

    class ScenWeaveWorker(Worker):
        def get_heartbeat_ttl(self, job: Any, working_time: float = 0.0) -> int:
            return 2 * self.job_monitoring_interval + 10

        def fork_work_horse(self, job: Any, queue: Any) -> None:
            self._worker_pid = os.getpid()
            super().fork_work_horse(job, queue)

        def main_work_horse(self, job: Any, queue: Any) -> None:
            # RQ puts the horse in its own process group, so it outlives a killed worker and
            # would race the retry of its job; make it die with the worker instead
            _die_with_parent(self._worker_pid)
            super().main_work_horse(job, queue)

    return ScenWeaveWorker([QUEUE_NAME], connection=connection,
                           job_monitoring_interval=options.heartbeat_s,
                           maintenance_interval=options.maintenance_interval_s,
                           worker_ttl=options.maintenance_interval_s + 15)


def _die_with_parent(parent_pid: int) -> None:
    import ctypes

    pr_set_pdeathsig = 1
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent_pid:  # the worker died before prctl took effect
        os._exit(1)


def preload(options: WorkerOptions) -> None:
    """Load the matcher and the pipeline's modules now, so forked work horses inherit them."""
    for module in options.preload_modules:
        # an optional part (e.g. the agent) not installed: the jobs needing it will say so
        with suppress(ImportError):
            importlib.import_module(module)
    if options.preload_matcher:
        matcher_for(options.preload_matcher, options.preload_map)


def work(url: str | None, options: WorkerOptions) -> bool:
    """Run one worker in this process until stopped (or the queue is empty with ``burst``)."""
    connection = connect(url)
    preload(options)
    return make_worker(connection, options).work(burst=options.burst, with_scheduler=True)


def work_in_processes(url: str | None, options: WorkerOptions, count: int) -> int:
    """Run ``count`` workers, each in its own process; return how many exited cleanly."""
    connect(url)  # fail here, once, with the clear message
    preload(options)
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

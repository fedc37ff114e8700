"""The queue: a run's scenarios as RQ jobs on Redis, done by workers on any machine.

Workers share nothing with the submitter but the queue. ``submit`` loads the input, opens
the run folder and enqueues one job per scenario (job id = run id + scenario id) carrying all
the scenario needs: the record's params (extracted with the run's layout), its spawn index,
the pipeline settings, the map by name or, for a map file, by content hash (the file itself
travels once per run through Redis), and a mined record's recorded series. A worker makes
the scenario in its own scratch folder and hands the finished folder back through Redis as a
compressed parcel (``handoff``; artefacts over the limits stay behind and the outcome lists
them); ``collect`` (``submit --wait``, ``scenweave collect RUN_DIR``) commits each parcel into
the run folder atomically, exactly once, and finishes the run with ``summary.json`` and
``report.html``. Nothing runs twice: a scenario committed, handed back or still queued/running
is not enqueued again (and RQ's ``unique`` enqueue makes two racing submits safe).

Retries are for infrastructure only: ``process_scenario`` turns every problem of a scenario
into a ``failed`` outcome and raises only infrastructure errors (LLM server down, sandbox
engine gone, disk full), which RQ retries with the delays of ``JobOptions``. A worker that
dies mid-job (SIGKILL, OOM, host reboot) stops heartbeating; another worker's maintenance
finds the abandoned job in the StartedJobRegistry and retries it. When the retries run out,
the scenario is handed back as ``failed`` with taxonomy ``infrastructure``, so the run still
completes and ``submit --retry-failed`` picks it up again.
"""

from __future__ import annotations

import fcntl
import hashlib
import importlib
import json
import multiprocessing
import os
import shutil
import signal
import sys
import tempfile
import threading
import uuid
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast
from urllib.parse import urlsplit, urlunsplit

from scenweave.errors import InfrastructureError, InputError
from scenweave.handoff import Limits, pack
from scenweave.inputs import InputSelection, load_input
from scenweave.maneuvers.plugins import DOCS, Registry, resolve
from scenweave.pipeline import PipelineSettings, base_outcome
from scenweave.progress import progress
from scenweave.report import write_run_report
from scenweave.run_folder import (
    RECORDED_NAME,
    RUN_FILE,
    STATUS_FILE,
    SUMMARY_FILE,
    RunFolder,
    safe_name,
)
from scenweave.runner import make_scenario, round_robin, run_description, summarize
from scenweave.schemas.params import Params

QUEUE_NAME = "scenweave"
QUEUE_ENV = "SCENWEAVE_QUEUE"
DEFAULT_QUEUE_URL = "redis://127.0.0.1:6379/0"
#: the spawn matcher a job uses: a name in ``SPAWN_MATCHERS`` (or a plugin's) or
#: ``module:callable``, called with the map's name (None: Town04)
DEFAULT_MATCHER = "default"
#: the built-in spawn matchers, declared as a plugin declares its own (``docs/plugins.md``)
SPAWN_MATCHERS = {DEFAULT_MATCHER: "scenweave.runner:default_matcher"}
#: RQ job states in which a job will still run: such a job is not enqueued a second time
PENDING_STATES = ("queued", "started", "scheduled", "deferred")
#: where a worker makes its scenarios unless told (``scenweave worker --scratch``)
SCRATCH_ENV = "SCENWEAVE_WORKER_SCRATCH"
LOCK_FILE = ".collect.lock"
#: reference scripts whose worked examples a worker makes once before work (``warm_up``)
WARM_UP_SCRIPTS = ("gen_hw_lcf.py", "gen_ur_stop_at_tfl_red.py")


class QueueError(InfrastructureError):
    """Root of the queue's infrastructure failures (Redis unreachable, ...)."""


@dataclass
class JobOptions:
    """How each scenario job is queued."""

    retries: int = 3
    retry_delays_s: tuple[int, ...] = (10, 60, 300)
    timeout_s: int = 3600
    result_ttl_s: int = 7 * 86400
    matcher: str = DEFAULT_MATCHER
    #: how large a scenario's artefacts may travel back through Redis
    limits: Limits = field(default_factory=Limits)


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
                                       "scenweave.replay_figures")
    #: the worker's own folder for scenarios in the making (None: a temp folder)
    scratch: Path | None = None
    #: make a highway and an urban example once before work (``warm_up``)
    warm_up: bool = True


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


@dataclass(frozen=True)
class RunKeys:
    """The Redis keys of one run's hand-back: parcels not collected yet, what was made (by
    which submission) and the scenarios the submitter still waits for."""

    run_id: str

    @property
    def parcels(self) -> str:
        return f"scenweave:run:{self.run_id}:parcels"

    @property
    def made(self) -> str:
        return f"scenweave:run:{self.run_id}:made"

    @property
    def pending(self) -> str:
        return f"scenweave:run:{self.run_id}:pending"


def map_key(sha256: str) -> str:
    """The Redis key holding a map file's compressed content."""
    return f"scenweave:map:{sha256}"


def queue_url(url: str | None = None) -> str:
    """The Redis URL to use: ``url``, else ``$SCENWEAVE_QUEUE``, else the local default."""
    return url or os.environ.get(QUEUE_ENV) or DEFAULT_QUEUE_URL


def redacted(url: str) -> str:
    """``url`` with its password replaced by ``***``, for messages and ``run.json``."""
    parts = urlsplit(url)
    if not parts.password:
        return url
    user = parts.username or ""
    host = parts.hostname or ""
    netloc = f"{user}:***@{host}" + (f":{parts.port}" if parts.port else "")
    return urlunsplit(parts._replace(netloc=netloc))


def connect(url: str | None = None) -> Any:
    """A checked connection to the Redis of ``url`` (``redis://`` or TLS ``rediss://``, a
    password as ``redis://:PASSWORD@host``); QueueError names the setting to change."""
    from redis import Redis
    from redis.exceptions import RedisError

    url = queue_url(url)
    try:
        connection = Redis.from_url(url)
        connection.ping()
    except (RedisError, ValueError) as err:
        if _is_refused_login(err):
            raise QueueError(f"the job queue at {redacted(url)} refused the login ({err}): it "
                             "needs its password in the URL, redis://:PASSWORD@host:6379/0 "
                             f"(--queue / {QUEUE_ENV})") from err
        raise QueueError(f"cannot reach the job queue at {redacted(url)}: {err}; start "
                         f"redis-server there or pass --queue / set {QUEUE_ENV} (a password "
                         "goes in the URL: redis://:PASSWORD@host:6379/0)") from err
    return connection


def _is_refused_login(err: Exception) -> bool:
    from redis.exceptions import AuthenticationError

    text = str(err)
    return isinstance(err, AuthenticationError) or "NOAUTH" in text or "authenticated" in text


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
    where = connection.connection_pool.connection_kwargs
    folder.write(RUN_FILE, {**description, "queue": _described_queue(where),
                            "input_issues": result.input_issues})
    try:
        queue = _queue(connection)
        job_map = share_map(connection, settings.map, options.result_ttl_s)
        for index, params in progress(round_robin(loaded.params), desc="enqueue",
                                      total=len(loaded.params)):
            spec = {"run_id": folder.run_id, "params": params, "index": index,
                    "settings": settings, "matcher": options.matcher, "map": job_map,
                    "recorded": loaded.recorded.get(params["scenario_id"]),
                    "limits": options.limits, "submission": result.submission,
                    "ttl_s": options.result_ttl_s}
            _submit_one(queue, folder, spec, retry_failed, options, result)
    except RedisError as err:
        raise QueueError(f"the job queue failed while enqueueing run {folder.run_id}: {err}; "
                         "check the Redis server, then submit the same --run-id again") from err
    return result


def _described_queue(kwargs: dict) -> dict:
    """Where the queue is, for ``run.json``: host, port and database, never the password."""
    return {"host": kwargs.get("host"), "port": kwargs.get("port"), "db": kwargs.get("db", 0)}


def share_map(connection: Any, map_name: str | None, ttl_s: int) -> dict | None:
    """What a job says about its map: a bundled town by name; a map file by name and content
    hash, its content stored once in Redis for workers that do not have the file."""
    from scenweave.roads import resolve_map

    if map_name is None:
        return None
    ref = resolve_map(map_name)
    if ref.bundled:
        return {"name": ref.name, "bundled": True}
    content = ref.path.read_bytes()
    sha256 = hashlib.sha256(content).hexdigest()
    connection.set(map_key(sha256), zlib.compress(content, 6), ex=ttl_s, nx=True)
    connection.expire(map_key(sha256), ttl_s)
    return {"name": ref.path.name, "path": str(ref.path), "sha256": sha256, "bundled": False}


def _submit_one(queue: Any, folder: RunFolder, spec: dict, retry_failed: bool,
                options: JobOptions, result: SubmitResult) -> None:
    from rq import Callback, Retry
    from rq.exceptions import DuplicateJobError, NoSuchJobError
    from rq.job import Job

    scenario_id = spec["params"]["scenario_id"]
    keys = RunKeys(folder.run_id)
    done = folder.outcome(scenario_id)
    redo = retry_failed and done is not None and done.get("status") == "failed"
    waiting = queue.connection.hexists(keys.parcels, scenario_id)
    if (done and not redo) or (waiting and done is None):
        result.already_done += 1  # committed, or handed back and waiting to be collected
        return
    jid = job_id(folder.run_id, scenario_id)
    try:
        old = Job.fetch(jid, connection=queue.connection)
        if old.get_status() in PENDING_STATES:
            result.already_queued += 1
            queue.connection.sadd(keys.pending, scenario_id)
            return
        old.delete()
    except NoSuchJobError:
        pass
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
    queue.connection.sadd(keys.pending, scenario_id)
    queue.connection.expire(keys.pending, options.result_ttl_s)
    result.enqueued.append(jid)


def _queue(connection: Any) -> Any:
    from rq import Queue

    return Queue(QUEUE_NAME, connection=connection)


# --- the job, in the worker ----------------------------------------------------------------

_matchers: dict[tuple[Callable[[str | None], Any], str | None], Any] = {}
_scratch_root: Path | None = None
_matcher_factories: Registry[Callable[[str | None], Any]] = Registry(
    "spawn matcher", "SPAWN_MATCHERS", expected="a callable making a matcher from a map name",
    accepts=callable, builtin_modules=[__name__])


def matcher_names() -> list[str]:
    """Every spawn matcher's name: ``default`` and the plugins'."""
    return _matcher_factories.names()


def matcher_factory(factory: str) -> Callable[[str | None], Any]:
    """The callable making the matchers ``factory`` names: a registered name or
    ``module:callable``; an :class:`InputError` naming ``--matcher`` and the choices."""
    found = _matcher_factories.find(factory)
    if found is None and ":" in factory:
        try:
            found = cast(Callable[[str | None], Any], resolve(factory))
        except (ImportError, AttributeError) as err:
            raise InputError(f"--matcher {factory}: {type(err).__name__}: {err}") from err
    if found is None:
        raise InputError(f"--matcher {factory!r}: no such spawn matcher (choose "
                         f"{', '.join(matcher_names())} or give module:callable; plugins add "
                         f"more, see {DOCS})")
    return found


def matcher_for(factory: str, map_name: str | None = None) -> Any:
    """The spawn matcher ``factory`` (a registered name or ``module:callable``) makes for
    ``map_name``, made once per process (``default`` and the callable it names alike)."""
    from scenweave.roads import DEFAULT_MAP

    make = matcher_factory(factory)
    key = (make, map_name or DEFAULT_MAP)
    if key not in _matchers:
        _matchers[key] = make(map_name)
    return _matchers[key]


def scratch_root() -> Path:
    """This worker's scratch folder: ``--scratch``, ``$SCENWEAVE_WORKER_SCRATCH``, or a
    folder of its own under the system's temp folder."""
    global _scratch_root
    if _scratch_root is None:
        chosen = os.environ.get(SCRATCH_ENV)
        _scratch_root = Path(chosen) if chosen else Path(
            tempfile.mkdtemp(prefix="scenweave-worker-"))
    _scratch_root.mkdir(parents=True, exist_ok=True)
    return _scratch_root


def run_job(spec: dict) -> str:
    """RQ job: make one scenario in this worker's scratch folder and hand the folder back
    through Redis; return its status.

    Idempotent: a scenario this submission already handed back (e.g. a retry after the
    worker died between the hand-back and telling Redis) is not made again.
    """
    from rq import get_current_job

    job = get_current_job()
    if job is None:
        raise QueueError("run_job runs as an RQ job (scenweave worker), not on its own")
    connection = job.connection
    keys = RunKeys(spec["run_id"])
    scenario_id = spec["params"]["scenario_id"]
    made_by = connection.hget(keys.made, scenario_id)
    if isinstance(made_by, bytes):
        made_by = made_by.decode()
    if made_by is not None and made_by == spec.get("submission"):
        return "handed back already"
    folder = scratch_root() / job_id(spec["run_id"], scenario_id)
    _remove(folder)  # leftovers of a dead attempt go
    folder.mkdir(parents=True)
    try:
        settings = _local_settings(spec["settings"], spec.get("map"), connection)
        if spec.get("recorded"):
            (folder / RECORDED_NAME).write_text(_json(spec["recorded"]), encoding="utf-8")
        matcher = matcher_for(spec.get("matcher") or DEFAULT_MATCHER, settings.map)
        try:
            outcome = make_scenario(spec["params"], spec["index"], folder, settings, matcher)
        finally:
            _close_agent()
        outcome["worker"] = job.worker_name
        hand_back(connection, spec, folder, outcome)
    finally:
        _remove(folder)
    return outcome["status"]


def hand_back(connection: Any, spec: dict, folder: Path, outcome: dict) -> int:
    """Put the scenario folder (with its outcome as ``status.json``) into Redis for the
    collector, in one transaction with the note that this submission made it; return the
    parcel's size in bytes."""
    limits = spec.get("limits") or Limits()
    outcome["submission"] = spec.get("submission")  # which submit made it: --retry-failed

    def status(dropped: list[dict]) -> dict[str, bytes]:
        if dropped:
            outcome["artefacts_left_behind"] = dropped
        return {STATUS_FILE: _json(outcome).encode("utf-8")}

    parcel = pack(folder, limits, extra=status)
    keys, scenario_id = RunKeys(spec["run_id"]), spec["params"]["scenario_id"]
    ttl = int(spec.get("ttl_s") or JobOptions.result_ttl_s)
    with connection.pipeline(transaction=True) as pipe:
        pipe.hset(keys.parcels, scenario_id, parcel.data)
        pipe.hset(keys.made, scenario_id, spec.get("submission") or "")
        pipe.expire(keys.parcels, ttl)
        pipe.expire(keys.made, ttl)
        pipe.execute()
    return len(parcel.data)


def _json(data: Any) -> str:
    return json.dumps(data, indent=1)


def _local_settings(settings: PipelineSettings, job_map: dict | None,
                    connection: Any) -> PipelineSettings:
    """The job's settings with its map file where this worker can read it: the same path if
    it holds the same content, else a copy fetched from Redis into the scratch folder."""
    if not job_map or job_map.get("bundled"):
        return settings
    path = Path(job_map["path"])
    with suppress(OSError):
        if hashlib.sha256(path.read_bytes()).hexdigest() == job_map["sha256"]:
            return settings
    copy = scratch_root() / "maps" / job_map["sha256"] / job_map["name"]
    if not copy.is_file():
        content = connection.get(map_key(job_map["sha256"]))
        if content is None:
            raise QueueError(f"map {job_map['name']} ({job_map['sha256'][:12]}) is no longer in "
                             "the queue; submit the run again")
        copy.parent.mkdir(parents=True, exist_ok=True)
        temporary = copy.with_suffix(".part")
        temporary.write_bytes(zlib.decompress(content))
        temporary.rename(copy)
    return replace(settings, map=str(copy))


def _remove(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)


def _close_agent() -> None:
    """Close the agent's LLM and sandbox (its warm pool) made for this job: the worker lives
    on for other runs, whose settings may differ, and a killed worker runs no ``atexit``."""
    agent_run = sys.modules.get("scenweave.agent.run")
    if agent_run is not None:
        agent_run.close_shared()


def on_job_failure(job: Any, connection: Any, exc_type: type, exc_value: BaseException,
                   traceback: Any) -> None:
    """RQ failure callback: once a job has no retries left, hand the scenario back failed."""
    if job.retries_left:
        return
    spec = job.args[0]
    scenario_id = spec["params"]["scenario_id"]
    made_by = connection.hget(RunKeys(spec["run_id"]).made, scenario_id)
    if made_by is not None and made_by.decode() == spec.get("submission"):
        return
    reason = str(exc_value) or "the worker died while running this scenario"
    outcome = {**base_outcome(spec["params"]), "error_taxonomy": ["infrastructure"],
               "error": f"{exc_type.__name__}: {reason} (no retries left; fix the "
                        "infrastructure, then submit again with --retry-failed)"}
    with tempfile.TemporaryDirectory(prefix="scenweave-failed-") as empty:
        hand_back(connection, spec, Path(empty), outcome)


# --- the run's summary and report, at the submitter --------------------------------------

@contextmanager
def run_lock(run_dir: Path) -> Iterator[None]:
    """The run folder's lock: collectors and summary writers take turns."""
    with open(run_dir / LOCK_FILE, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def refresh_run(run_dir: Path) -> dict:
    """Rewrite the run's ``summary.json``; write ``report.html`` once every scenario is in.

    Collectors and summary writers take turns (a lock file in the run folder), so the last
    one to write has seen every committed scenario.
    """
    folder = RunFolder(Path(run_dir))
    with run_lock(folder.root):
        run = _read_json(folder.root / RUN_FILE)
        issues = run.get("input_issues", _read_json(folder.root / SUMMARY_FILE).get("input_issues"))
        summary = summarize(folder, issues or [])
        folder.write(SUMMARY_FILE, summary)
        if summary["total"] >= expected_scenarios(folder.root):
            write_run_report(folder.root)
    return summary


def expected_scenarios(run_dir: Path) -> int:
    """How many scenarios the run has (``run.json``)."""
    return int(_read_json(Path(run_dir) / RUN_FILE).get("scenarios") or 0)


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return {}


# --- worker processes ----------------------------------------------------------------------

def make_worker(connection: Any, options: WorkerOptions) -> Any:
    """An RQ worker on the ScenWeave queue that runs each job in its own process, warm, and
    whose abandoned jobs are found quickly.

    RQ's default worker forks a fresh work horse per job, which throws away every cache a
    scenario fills (spawn lanes, XSD, the player's server and road graph, matplotlib's fonts):
    1.7 s instead of 0.3 s per scenario, measured. This one is RQ's ``SimpleWorker`` (the job
    runs in the worker, which dies with it: nothing outlives a killed worker to race the
    retry) with a heartbeat thread, so a job's registry entry still lives only two heartbeats
    plus 10 s; an idle worker wakes every maintenance interval to look for abandoned jobs
    (RQ's default is every 10 minutes).
    """
    from rq import SimpleWorker
    from rq.worker import WorkerStatus

    class ScenWeaveWorker(SimpleWorker):
        _beating: tuple[threading.Event, threading.Thread] | None = None

        def get_heartbeat_ttl(self, job: Any, working_time: float = 0.0) -> int:
            return 2 * self.job_monitoring_interval + 10

        def execute_job(self, job: Any, queue: Any) -> None:
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
            self.set_state(WorkerStatus.IDLE)

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
    global _scratch_root
    if options.scratch is not None:
        _scratch_root = Path(options.scratch)
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

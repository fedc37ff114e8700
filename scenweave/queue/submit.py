"""Submitting a run: ``submit`` loads the input, opens the run folder and enqueues one job per
scenario (job id = run id + scenario id) carrying all the scenario needs: the record's params
(extracted with the run's layout), its spawn index, the pipeline settings, the map by name or,
for a map file, by content hash (the file itself travels once per run through Redis), and a
mined record's recorded series. Nothing runs twice: a scenario committed, handed back or still
queued/running is not enqueued again (and RQ's ``unique`` enqueue makes two racing submits
safe).
"""

from __future__ import annotations

import hashlib
import uuid
import zlib
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from scenweave.inputs import InputSelection, load_input
from scenweave.pipeline import PipelineSettings
from scenweave.progress import progress
from scenweave.queue.connection import (
    QUEUE_NAME,
    QueueError,
    RunKeys,
    job_id,
    map_key,
    riding_out,
)
from scenweave.queue.job import JobOptions, on_job_failure, run_job
from scenweave.run_folder import RunFolder
from scenweave.runner import round_robin, run_description
from scenweave.schemas.scenario_folder import RUN_FILE

#: RQ job states in which a job will still run: such a job is not enqueued a second time
PENDING_STATES = ("queued", "started", "scheduled", "deferred")


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
        job_map = riding_out(partial(share_map, connection, settings.map, options.result_ttl_s),
                             connection)
        for index, params in progress(round_robin(loaded.params), desc="enqueue",
                                      total=len(loaded.params)):
            spec = {"run_id": folder.run_id, "params": params, "index": index,
                    "settings": settings, "matcher": options.matcher, "map": job_map,
                    "recorded": loaded.recorded.get(params["scenario_id"]),
                    "limits": options.limits, "submission": result.submission,
                    "ttl_s": options.result_ttl_s}
            riding_out(partial(_submit_one, queue, folder, spec, retry_failed, options, result),
                       connection)  # idempotent: a job queued already is not queued again
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
    done = folder.trusted_outcome(scenario_id)
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

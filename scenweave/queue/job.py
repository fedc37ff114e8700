"""The job, in the worker: one scenario made in the worker's scratch folder and handed back
through Redis as a parcel (``handoff``), or, once its retries ran out, handed back ``failed``.

Retries are for infrastructure only: ``process_scenario`` turns every problem of a scenario
into a ``failed`` outcome and raises only infrastructure errors (LLM server down, sandbox
engine gone, disk full), which RQ retries with the delays of ``JobOptions``. When the retries
run out, ``on_job_failure`` hands the scenario back as ``failed`` with taxonomy
``infrastructure``, so the run still completes and ``submit --retry-failed`` picks it up again.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import tempfile
import zlib
from contextlib import suppress
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from scenweave.pipeline import PipelineSettings, base_outcome
from scenweave.player.scratch import owned_folder, scratch_parent, use_scratch_parent
from scenweave.queue.connection import QueueError, RunKeys, job_id, map_key, riding_out
from scenweave.queue.handoff import Limits, pack
from scenweave.runner import make_scenario
from scenweave.schemas.scenario_folder import RECORDED_NAME, STATUS_NAME
from scenweave.spawn_db.registry import DEFAULT_MATCHER, matcher_for

#: where a worker makes its scenarios unless told (``scenweave worker --scratch``)
SCRATCH_ENV = "SCENWEAVE_WORKER_SCRATCH"


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


_scratch_root: Path | None = None
def scratch_root() -> Path:
    """This worker's scratch folder: ``--scratch``, ``$SCENWEAVE_WORKER_SCRATCH``, or a
    folder of its own beside the player's (named after this process: the next start sweeps
    it once this worker is gone, killed or not). The player's folders go inside it."""
    global _scratch_root
    if _scratch_root is None:
        chosen = os.environ.get(SCRATCH_ENV)
        _scratch_root = Path(chosen) if chosen else owned_folder(scratch_parent(), "worker")
    _scratch_root.mkdir(parents=True, exist_ok=True)
    use_scratch_parent(_scratch_root)
    return _scratch_root


def use_scratch_root(path: Path) -> None:
    """Make scenarios under ``path`` from now on (``scenweave worker --scratch``)."""
    global _scratch_root
    _scratch_root = Path(path)
    use_scratch_parent(_scratch_root)


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
    made_by = riding_out(lambda: connection.hget(keys.made, scenario_id), connection)
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
        return {STATUS_NAME: _json(outcome).encode("utf-8")}

    parcel = pack(folder, limits, extra=status)
    keys, scenario_id = RunKeys(spec["run_id"]), spec["params"]["scenario_id"]
    ttl = int(spec.get("ttl_s") or JobOptions.result_ttl_s)

    def put() -> None:  # one transaction, the same each time: handing back twice is once
        with connection.pipeline(transaction=True) as pipe:
            pipe.hset(keys.parcels, scenario_id, parcel.data)
            pipe.hset(keys.made, scenario_id, spec.get("submission") or "")
            pipe.expire(keys.parcels, ttl)
            pipe.expire(keys.made, ttl)
            pipe.execute()

    # Redis away: the made folder waits for it here (a QueueError past the outage budget
    # fails the attempt, and RQ's retry makes and hands it back again)
    riding_out(put, connection)
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

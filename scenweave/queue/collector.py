"""The submitter's side of the queue: the scenario folders workers handed back, into the run
folder, and the run finished with ``summary.json`` and ``report.html``.

``collect`` takes every parcel of the run waiting in Redis, unpacks it into the scenario's
staging folder and commits it with one rename, then deletes the parcel. Collectors take turns
(a lock file in the run folder), and a parcel whose scenario is already committed is dropped,
so each scenario is written exactly once however often ``collect`` runs or dies; a collector
killed between the commit and the delete finds the folder committed next time. With ``wait``
it goes on until no scenario of the run is pending in the queue, or the jobs still pending
are gone (a flushed Redis, a cancelled job): those are named, to be submitted again.
"""

from __future__ import annotations

import fcntl
import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from scenweave.pipeline import base_outcome
from scenweave.presentation.report import write_run_report
from scenweave.queue.connection import QueueError, RunKeys, job_id, riding_out
from scenweave.queue.handoff import ParcelError, unpack
from scenweave.run_folder import RunFolder
from scenweave.runner import summarize
from scenweave.schemas.scenario_folder import (
    REPORT_FILE,
    RUN_FILE,
    STATUS_NAME,
    SUMMARY_FILE,
    read_json_object,
)

LOCK_FILE = ".collect.lock"
#: RQ job states from which a job without a hand-back will never hand one back
GONE_STATES = ("failed", "stopped", "canceled")


@dataclass
class CollectResult:
    """What ``collect`` did to a run folder."""

    folder: RunFolder
    committed: list[str] = field(default_factory=list)
    duplicates: int = 0
    pending: int = 0
    lost: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    summary: dict = field(default_factory=dict)

    expected: int = 0

    @property
    def complete(self) -> bool:
        return self.summary.get("total", 0) >= self.expected

    def line(self) -> str:
        """The one-line summary printed at the end of ``collect`` and ``submit --wait``."""
        total, expected = self.summary.get("total", 0), self.expected
        counts = self.summary.get("counts") or {}
        statuses = ", ".join(f"{n} {s}" for s, n in counts.items())
        queued = self.pending - len(self.lost)
        waiting = f", {queued} still queued" if queued else ""
        lost = (f", {len(self.lost)} no longer in the queue (submit the same --run-id again)"
                if self.lost else "")
        report = (f" (open {self.folder.root / REPORT_FILE})"
                  if (self.folder.root / REPORT_FILE).exists() and self.complete else "")
        return (f"run {self.folder.run_id}: collected {len(self.committed)}, {total} of "
                f"{expected} scenarios in the run folder: {statuses}{waiting}{lost} -> "
                f"{self.folder.root}{report}")


def collect(run_dir: Path, connection: Any, wait: bool = False, timeout_s: float | None = None,
            poll_s: float = 0.5, on_commit: Callable[[int], None] | None = None
            ) -> CollectResult:
    """Commit the run's handed-back scenario folders; with ``wait``, until none is pending.

    Redis going away meanwhile is waited out (``riding_out``: each round is idempotent); a
    Redis back without its data (no append-only file) has forgotten the pending scenarios:
    those seen pending and not in the run folder are named lost, to be submitted again."""
    from redis.exceptions import RedisError

    folder = RunFolder(Path(run_dir))
    if not (folder.root / RUN_FILE).is_file():
        raise QueueError(f"{folder.root} is not a run folder of a submit (no {RUN_FILE})")
    result, keys = CollectResult(folder), RunKeys(folder.run_id)
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    suspects: set[str] = set()
    seen: set[str] = set()
    pending: set[str] = set()
    try:
        while True:
            got, pending = riding_out(lambda: _round(folder, connection, keys, result),
                                      connection)
            seen |= pending
            if on_commit and got:
                on_commit(got)
            result.pending = len(pending)
            if not wait or not pending:
                break
            gone = riding_out(partial(_gone, connection, folder, pending), connection)
            result.lost = sorted(gone & suspects)  # gone twice in a row: not a race
            suspects = gone
            if pending <= set(result.lost):
                break
            if deadline is not None and time.monotonic() > deadline:
                break
            if got:
                refresh_run(folder.root)  # the summary follows the run while it is waited on
            time.sleep(poll_s)
    except RedisError as err:
        raise QueueError(f"the job queue failed while collecting run {folder.run_id}: {err}; "
                         "check the Redis server, then run scenweave collect again") from err
    if wait:  # pending once, now neither pending nor in the run folder: Redis forgot them
        forgotten = {s for s in seen - pending - set(result.lost) if folder.outcome(s) is None}
        result.lost = sorted({*result.lost, *forgotten})
        result.pending += len(forgotten)
    result.summary = refresh_run(folder.root)
    result.expected = expected_scenarios(folder.root)
    return result


def _round(folder: RunFolder, connection: Any, keys: RunKeys,
           result: CollectResult) -> tuple[int, set[str]]:
    """One look at the queue: commit what was handed back; return how many scenario folders
    were written and which scenarios are still pending."""
    got = _collect_once(folder, connection, keys, result)
    return got, {m.decode() for m in connection.smembers(keys.pending)}


def _collect_once(folder: RunFolder, connection: Any, keys: RunKeys,
                  result: CollectResult) -> int:
    """Commit every parcel waiting now; return how many scenario folders were written."""
    committed = 0
    with run_lock(folder.root):
        for raw in connection.hkeys(keys.parcels):
            scenario_id = raw.decode()
            data = connection.hget(keys.parcels, scenario_id)
            if data is not None and _commit_parcel(folder, scenario_id, data, result):
                committed += 1
                result.committed.append(scenario_id)
            # only after the commit: a collector dying in between finds the folder next time
            with connection.pipeline(transaction=True) as pipe:
                pipe.hdel(keys.parcels, scenario_id)
                pipe.srem(keys.pending, scenario_id)
                pipe.execute()
    return committed


def _commit_parcel(folder: RunFolder, scenario_id: str, data: bytes,
                   result: CollectResult) -> bool:
    staging = folder.staging(scenario_id)
    try:
        unpack(data, staging)
        outcome = json.loads((staging / STATUS_NAME).read_text(encoding="utf-8"))
    except (ParcelError, OSError, json.JSONDecodeError) as err:
        staging = folder.staging(scenario_id)
        outcome = {**base_outcome({"scenario_id": scenario_id, "maneuver_class": "?",
                                   "domain": "?"}),
                   "error_taxonomy": ["infrastructure"],
                   "error": f"the worker's hand-back could not be read ({err}); submit again "
                            "with --retry-failed"}
    done = folder.trusted_outcome(scenario_id)
    if done is not None and not (done.get("status") == "failed"
                                 and done.get("submission") != outcome.get("submission")):
        result.duplicates += 1
        _discard(staging)
        return False
    for left in outcome.get("artefacts_left_behind") or []:
        result.notes.append(f"{scenario_id}: {left['file']} ({left['bytes']} bytes) not handed "
                            f"back: {left['reason']}")
    folder.commit(scenario_id, staging, outcome)
    return True


def _discard(path: Path) -> None:
    import shutil

    shutil.rmtree(path, ignore_errors=True)


def _gone(connection: Any, folder: RunFolder, pending: set[str]) -> set[str]:
    """The pending scenarios whose job is gone or ended without handing anything back."""
    from rq.exceptions import NoSuchJobError
    from rq.job import Job

    gone = set()
    keys = RunKeys(folder.run_id)
    for scenario_id in pending:
        if connection.hexists(keys.parcels, scenario_id):
            continue
        try:
            status = Job.fetch(job_id(folder.run_id, scenario_id),
                               connection=connection).get_status()
        except NoSuchJobError:
            status = None
        if status is None or status in GONE_STATES:
            gone.add(scenario_id)
    return gone


# --- the run's summary and report -------------------------------------------------------

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
        run = read_json_object(folder.root / RUN_FILE)
        issues = run.get("input_issues",
                         read_json_object(folder.root / SUMMARY_FILE).get("input_issues"))
        summary = summarize(folder, issues or [])
        folder.write(SUMMARY_FILE, summary)
        if summary["total"] >= expected_scenarios(folder.root):
            write_run_report(folder.root)
    return summary


def expected_scenarios(run_dir: Path) -> int:
    """How many scenarios the run has (``run.json``)."""
    return int(read_json_object(Path(run_dir) / RUN_FILE).get("scenarios") or 0)

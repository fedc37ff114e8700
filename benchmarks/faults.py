"""Faults injected with real processes, and what reached the run folder.

Per fault, one line: scenarios delivered once / lost / doubled / half-written (a file its
status.json names missing or unreadable), those not ok, the exit codes of the commands the
user ran (the first, and the one step it named when it asked for one) and the seconds from
the fault to the finished run (or, for esmini's crash, to the next ok scenario in). The faults
(``scenweave.testing.faults`` and ``.run_faults``, which ``tests/faults/`` asserts on too):

- redis-aof: Redis SIGKILLed once two scenarios are in, restarted 2 s later on the same
  port, with its append-only file, under two ``scenweave worker`` and a ``submit --wait``;
- redis-bare: the same without persistence (Redis comes back empty: the submitter names the
  lost scenarios and exits 1; submitting the same --run-id again finishes the run);
- worker: a ``scenweave worker`` SIGKILLed mid-job: its RQ scheduler must end with it, its
  scratch folders must go at the next worker's start, its job is redone by that worker;
- redis-late: a worker started while Redis is down waits for it (said once), then works;
- run-kill: ``scenweave run`` SIGKILLed once two scenarios are in, then ``run --resume``;
- disk-full: ``run`` into a 600 KiB tmpfs (needs root to mount: else not measured, saying
  why), then, grown to 64 MiB, the step its error line names (``--run-id full``);
- esmini-crash: every esmini child of the run's player server SIGSEGVed until the first
  scenario is in: that scenario fails (REPLAY_ENGINE, "esmini crashed"), the rest go on;
- damaged: a finished run's status.json truncated, scenario.xosc deleted and params.json
  damaged, then the same command: those three are made again, the rest kept.

    .venv/bin/python benchmarks/faults.py [--per-class 2] [--only run-kill,disk-full,...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.testing import run_faults  # noqa: E402
from scenweave.testing.faults import FaultBench, redis_restart, worker_killed  # noqa: E402

QUEUE_FAULTS = ("redis-aof", "redis-bare", "worker")
RUN_FAULTS = ("redis-late", "run-kill", "disk-full", "esmini-crash", "damaged")
FAULTS = QUEUE_FAULTS + RUN_FAULTS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=2,
                        help="sample records per class (4 classes)")
    parser.add_argument("--only", default=",".join(FAULTS), help="faults to inject, of "
                        + ", ".join(FAULTS))
    args = parser.parse_args()
    chosen = [f for f in args.only.split(",") if f]
    with tempfile.TemporaryDirectory(prefix="scenweave-faults-") as tmp:
        bench = FaultBench.make(Path(tmp), per_class=args.per_class)
        for fault in chosen:
            run_fault(bench, fault)


def run_fault(bench: FaultBench, fault: str) -> None:
    """Inject ``fault`` and print its line (and what a killed worker left behind)."""
    if fault == "worker":
        killed = worker_killed(bench)
        print(killed.delivery.line())
        print(f"{'':<40} scheduler processes alive after the kill: "
              f"{len(killed.schedulers_alive_after_kill)} of {len(killed.scheduler_pids)}; "
              f"scratch folders left after the next start: "
              f"{len(killed.scratch_after_next_start)} (were {len(killed.scratch_after_kill)})")
    elif fault in QUEUE_FAULTS:
        print(redis_restart(bench, appendonly=fault == "redis-aof").line())
    else:
        print(fault_of_a_run(bench, fault))
    sys.stdout.flush()


def fault_of_a_run(bench: FaultBench, fault: str) -> str:
    """The line of a fault of ``run`` or of a worker's start (``testing.run_faults``)."""
    if fault == "redis-late":
        return run_faults.worker_before_redis(bench).line()
    if fault == "run-kill":
        return run_faults.run_killed(bench).line()
    if fault == "disk-full":
        why_not = run_faults.mount_problem()
        return (f"{'disk full (ENOSPC)':<40} not measured: {why_not}" if why_not else
                run_faults.disk_full(bench).line())
    if fault == "esmini-crash":
        crashed, outcome = run_faults.esmini_crashed(bench)
        finding = ((outcome.get("validation") or {}).get("errors") or [{}])[0]
        return (f"{crashed.line()}\n{'':<40} the failed scenario's finding: "
                f"{finding.get('code')}: {finding.get('message')}")
    if fault == "damaged":
        return run_faults.damaged_on_resume(bench)[0].line()
    raise SystemExit(f"unknown fault {fault!r}: one of {', '.join(FAULTS)}")


if __name__ == "__main__":
    main()

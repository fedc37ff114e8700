"""Faults injected into the queue with real processes, and what reached the run folder.

Per fault, one line: scenarios delivered once / lost / doubled, those not ok, the exit codes
of the commands the user ran (the submitter, and the one step it named when it asked for
one) and the seconds from the fault (Redis back, or the worker killed) to the finished run.
The faults (``scenweave.testing.faults``, which ``tests/faults/`` asserts on too):

- Redis SIGKILLed once two scenarios are in, restarted 2 s later on the same port, with its
  append-only file, under two ``scenweave worker`` and a ``scenweave submit --wait``;
- the same without persistence (Redis comes back empty: the submitter names the lost
  scenarios and exits 1; submitting the same --run-id again finishes the run);
- a ``scenweave worker`` SIGKILLed mid-job: its RQ scheduler must end with it, its scratch
  folders must go at the next worker's start, its job is redone by that worker.

    .venv/bin/python benchmarks/faults.py [--per-class 2] [--only redis-aof,redis-bare,worker]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.testing.faults import FaultBench, redis_restart, worker_killed  # noqa: E402

FAULTS = ("redis-aof", "redis-bare", "worker")


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
    else:
        print(redis_restart(bench, appendonly=fault == "redis-aof").line())
    sys.stdout.flush()


if __name__ == "__main__":
    main()

"""Validated scenarios per second of ``scenweave run --no-llm`` on one core, and where time goes.

Target (issue 4): >= 100 validated scenarios/s for 2,000 records. The sample data is made
first; the run happens in a child process pinned to one core. With ``--qc`` every produced
scenario also goes through the ASAM quality checker (slow; not part of the timing).

    .venv/bin/python benchmarks/pipeline.py [--records 2000] [--qc] [--cpu 0]

The run folder goes under ``$TMPDIR``: ``TMPDIR=/dev/shm`` measures the pipeline without the
disk (each scenario writes about ten small files, and a VM's disk can dominate).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

URBAN_SHARE = 0.04  # urban data is scarce (thesis §6.5): a few per cent of the records


def measure(raw: Path, out: Path) -> dict:
    """Run the deterministic pipeline over ``raw``; time it and split the time by stage."""
    from scenweave.inputs import InputSelection
    from scenweave.pipeline import PipelineSettings
    from scenweave.runner import default_matcher, run_batch

    matcher = default_matcher()  # loading the spawn database is start-up, not per scenario
    start = time.perf_counter()
    result = run_batch(raw, out, InputSelection(), PipelineSettings(no_llm=True), run_id="bench",
                       matcher=matcher)
    elapsed = time.perf_counter() - start
    outcomes = result.summary["scenarios"]
    stages: dict[str, list[float]] = {}
    for outcome in outcomes:
        for stage, seconds in outcome["timings_s"].items():
            stages.setdefault(stage, []).append(seconds)
    return {
        "scenarios": len(outcomes), "counts": result.summary["counts"],
        "elapsed_s": round(elapsed, 2), "per_s": round(len(outcomes) / elapsed, 1),
        "stage_mean_ms": {k: round(statistics.fmean(v) * 1000, 3) for k, v in stages.items()},
        "run_dir": str(result.folder.root),
    }


def quality_check(run_dir: Path) -> tuple[int, int]:
    """Files checked and issues the ASAM quality checker reports over a run."""
    from scenweave.judge import run_asam_qc

    files = sorted(run_dir.glob("*/scenario.xosc"))
    return len(files), sum(len(run_asam_qc(path)) for path in files)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=2000)
    parser.add_argument("--qc", action="store_true", help="also run the ASAM quality checker")
    parser.add_argument("--cpu", type=int, default=0,
                        help="the core the run is pinned to (on a VM one may be busier)")
    parser.add_argument("--child", nargs=2, metavar=("RAW", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(Path(args.child[0]), Path(args.child[1]))))
        return
    from scenweave.ingest.samples import write_highway_samples, write_urban_samples

    urban_per_class = max(1, round(args.records * URBAN_SHARE / 5))
    highway_per_class = max(1, round((args.records - 5 * urban_per_class) / 12))
    with tempfile.TemporaryDirectory() as tmp:
        raw, out = Path(tmp) / "raw", Path(tmp) / "runs"
        write_highway_samples(raw / "highway", seed=2, per_class=highway_per_class)
        write_urban_samples(raw / "urban", seed=2, per_class=urban_per_class)
        pin = ["taskset", "-c", str(args.cpu)] if os.path.exists("/usr/bin/taskset") else []
        child = subprocess.run([*pin, sys.executable, __file__, "--child", str(raw), str(out)],
                               check=True, capture_output=True, text=True)
        result = json.loads(child.stdout.strip().splitlines()[-1])
        print(f"scenweave run --no-llm, one core: {result['scenarios']} scenarios in "
              f"{result['elapsed_s']} s = {result['per_s']} validated scenarios/s "
              f"(target >= 100: {'met' if result['per_s'] >= 100 else 'MISSED'})")
        print(f"outcomes: {result['counts']}")
        print("mean time per scenario by stage (ms): " + ", ".join(
            f"{k} {v}" for k, v in result["stage_mean_ms"].items()))
        if args.qc:
            checked, issues = quality_check(Path(result["run_dir"]))
            print(f"ASAM quality checker: {checked} scenarios, {issues} issues")


if __name__ == "__main__":
    main()

"""Ingest + extract throughput and peak memory on 240,000 highway rows (20,000 per class).

Target (issue 2): under 30 s on one core, peak memory under 1 GB. The sample files are made
first; the measured run happens in a fresh child process pinned to one core, so its peak
RSS is the ingest's own.

    .venv/bin/python benchmarks/ingest.py [--per-class 20000]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def measure(raw: Path, out: Path) -> dict:
    """Ingest ``raw`` into ``out`` and extract params of every record; time and memory."""
    from scenweave.ingest import extract_params, ingest_directory, load_records

    start = time.perf_counter()
    report = ingest_directory(raw, out)
    ingested = time.perf_counter()
    params = sum(1 for record in load_records(out) if extract_params(record))
    done = time.perf_counter()
    return {
        "rows": report.records_written, "issues": len(report.issues), "params": params,
        "ingest_s": round(ingested - start, 2), "extract_s": round(done - ingested, 2),
        "total_s": round(done - start, 2),
        "rows_per_s": round(report.records_written / (done - start)),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=20_000)
    parser.add_argument("--child", nargs=2, metavar=("RAW", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(Path(args.child[0]), Path(args.child[1]))))
        return
    from scenweave.ingest.samples import write_highway_samples

    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "raw"
        write_highway_samples(raw / "highway", seed=1, per_class=args.per_class)
        pin = ["taskset", "-c", "0"] if os.path.exists("/usr/bin/taskset") else []
        child = subprocess.run(
            [*pin, sys.executable, __file__, "--child", str(raw), str(Path(tmp) / "out")],
            check=True, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
        result = json.loads(child.stdout)
    print(f"ingest+extract of {result['rows']:,} highway rows on one core: "
          f"{result['total_s']} s (ingest {result['ingest_s']} s, extract {result['extract_s']} s)"
          f", {result['rows_per_s']:,} rows/s, peak RSS {result['peak_rss_mb']} MB, "
          f"{result['issues']} issues")
    verdict = result["total_s"] < 30 and result["peak_rss_mb"] < 1024
    print(f"target (< 30 s, < 1 GB): {'met' if verdict else 'MISSED'}")


if __name__ == "__main__":
    main()

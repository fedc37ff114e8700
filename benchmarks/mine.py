"""How fast ``scenweave mine`` turns driving into records, on one core.

Target (issue 14, item 6): mining is never the slow stage, at least 100x faster than real
time; the HTML report renders in under a tenth of the mining time (issue 23, item 4).
Default data: the four NGSIM US-101 snippets of ``../shared/data/ngsim/us101``. Prints
vehicle-hours of driving, the wall time of reading, of detection, of the whole mine (read,
detect, check, write; median of ``--repeat`` runs) and the factor over real time (vehicle-time
mined per second of wall time).

    .venv/bin/python benchmarks/mine.py [DATA] [--repeat 5] [--cpu 0]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.mining.detect import detect  # noqa: E402
from scenweave.mining.mine import mine_recordings  # noqa: E402
from scenweave.mining.readers import read_recordings  # noqa: E402
from scenweave.mining.thresholds import load_thresholds  # noqa: E402
from scenweave.presentation.mining_report import write_mining_report  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "ngsim" / "us101"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", nargs="?", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--cpu", type=int, default=0, help="The one core to run on.")
    args = parser.parse_args()
    if not args.data.exists():
        sys.exit(f"no data at {args.data} (give a file or folder scenweave mine reads)")
    os.sched_setaffinity(0, {args.cpu})
    print(json.dumps(measure(args.data, args.repeat), indent=1))


def measure(data: Path, repeat: int) -> dict:
    limits = load_thresholds()
    recordings = list(read_recordings(data))  # warm: imports, caches
    vehicle_s = sum(t.duration_s for r in recordings for t in r.tracks)
    read_s = _median(lambda: list(read_recordings(data)), repeat)
    detect_s = _median(lambda: [detect(r, limits) for r in recordings], repeat)
    with tempfile.TemporaryDirectory() as out:
        whole_s = _median(lambda: mine_recordings(read_recordings(data), Path(out), limits),
                          repeat)
        report = json.loads((Path(out) / "mining_report.json").read_text())
        written = report["records_written"]
        report_s = _median(lambda: write_mining_report(Path(out) / "mining_report.json"),
                           repeat)
    return {
        "data": str(data), "files": len(recordings),
        "tracks": sum(len(r.tracks) for r in recordings),
        "vehicle_hours": round(vehicle_s / 3600, 4), "records_written": written,
        "read_s": round(read_s, 3), "detect_s": round(detect_s, 3),
        "mine_s (read+detect+check+write)": round(whole_s, 3),
        "report_s (mining_report.html)": round(report_s, 4),
        "report_share_of_mine": round(report_s / whole_s, 4),
        "vehicle_hours_per_s": round(vehicle_s / 3600 / whole_s, 3),
        "times_real_time": round(vehicle_s / whole_s, 1),
    }


def _median(work, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        work()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


if __name__ == "__main__":
    main()

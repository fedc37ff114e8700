"""The round trip of mined events: data -> mined records -> scenarios -> esmini replay -> the
replayed trajectories mined again -> the same class, and the record's fields within 0.5 m/s,
1 m, 0.2 s (issue 14, item 3).

Prints, per class: events found, records written, scenarios made (ok after the replay),
round trips that hold, and the worst misses. Default data: the four NGSIM US-101 snippets of
``../shared/data/ngsim/us101`` (CommonRoad XML); any file or folder ``scenweave mine`` reads
works.

    .venv/bin/python benchmarks/roundtrip.py [DATA] [--jobs 2] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.ingest import load_records  # noqa: E402
from scenweave.inputs import InputSelection  # noqa: E402
from scenweave.mining.mine import mine_recordings  # noqa: E402
from scenweave.mining.readers import read_recordings  # noqa: E402
from scenweave.mining.roundtrip import RoundTrip, round_trip  # noqa: E402
from scenweave.mining.thresholds import load_thresholds  # noqa: E402
from scenweave.pipeline import PipelineSettings  # noqa: E402
from scenweave.player import Playback, ReplaySettings  # noqa: E402
from scenweave.run_folder import safe_name  # noqa: E402
from scenweave.runner import run_batch  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "ngsim" / "us101"
WORST_SHOWN = 3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", nargs="?", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--keep", type=Path, help="Keep records and runs in this folder.")
    args = parser.parse_args()
    if not args.data.exists():
        sys.exit(f"no data at {args.data} (give a file or folder scenweave mine reads)")
    with tempfile.TemporaryDirectory() as scratch:
        work = args.keep or Path(scratch)
        print(json.dumps(measure(args.data, work, args.jobs), indent=1))


def measure(data: Path, work: Path, jobs: int) -> dict:
    limits = load_thresholds()
    report = mine_recordings(read_recordings(data), work / "records", limits)
    found = Counter(code for f in report.files.values()
                    for code, n in f["events_by_class"].items() for _ in range(n))
    run = run_batch(work / "records", work / "runs", InputSelection(),
                    PipelineSettings(no_llm=True, replay=ReplaySettings()), run_id="roundtrip",
                    jobs=jobs)
    status = {o["scenario_id"]: o["status"] for o in run.summary["scenarios"]}
    trips: dict[str, list[RoundTrip]] = defaultdict(list)
    for record in load_records(work / "records"):
        if status.get(record["scenario_id"]) != "ok":
            continue
        folder = run.folder.root / safe_name(record["scenario_id"])
        trips[record["maneuver_class"]].append(
            round_trip(record, Playback.read(folder / "replay.json"), limits))
    return {"data": str(data), "vehicle_hours": round(report.vehicle_hours, 3),
            "classes": {code: _row(found[code], report.written.get(code, 0),
                                   [s for s, v in status.items() if v == "ok"
                                    and s.startswith(f"{code}_")], trips[code])
                        for code in sorted(found)}}


def _row(found: int, written: int, ok: list[str], trips: list[RoundTrip]) -> dict:
    missed = sorted((t for t in trips if not t.holds), key=lambda t: t.found)
    return {"events_found": found, "records_written": written, "scenarios_ok": len(ok),
            "round_trips_hold": sum(t.holds for t in trips), "round_trips": len(trips),
            "worst_misses": [f"{t.scenario_id}: {t.worst}" for t in missed[:WORST_SHOWN]]}


if __name__ == "__main__":
    main()

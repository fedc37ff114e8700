"""Spawn database build time, map load time, and SpawnMatcher find/assign throughput.

The build must be quick enough to run inside the tests (and deterministic) and on a map's first
use (``spawn_db.spawn_database`` builds and caches it); assign runs once per scenario in
``scenweave run``, whose target is >= 100 scenarios/s on one core, so it must stay a small part
of 10 ms.

    .venv/bin/python benchmarks/spawn_db.py [--map Town06] [--records-per-class 20]
"""

from __future__ import annotations

import argparse
import hashlib
import resource
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def _timed(action):
    start = time.perf_counter()
    result = action()
    return result, time.perf_counter() - start


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records-per-class", type=int, default=20)
    parser.add_argument("--map", default="Town04", help="a bundled town or an .xodr path")
    args = parser.parse_args()

    from scenweave.ingest import IngestReport, extract_params, iter_raw_records
    from scenweave.ingest.samples import write_highway_samples, write_urban_samples
    from scenweave.roads import load_opendrive, resolve_map
    from scenweave.spawn_db import SpawnMatcher, build_database, spawn_database
    from scenweave.spawn_db.database import write_database

    town = resolve_map(args.map)
    map_path = town.path
    _, parse_s = _timed(lambda: load_opendrive(map_path))
    print(f"parse {map_path.name} ({map_path.stat().st_size / 1e6:.1f} MB): {parse_s:.2f} s")
    with tempfile.TemporaryDirectory() as folder:
        for use in ("first", "second"):
            db_path, use_s = _timed(lambda: spawn_database(town, Path(folder) / "cache"))
            print(f"spawn_database, {use} use: {use_s:.2f} s -> {db_path.name}")
        digests = []
        for attempt in range(2):
            database, build_s = _timed(lambda: build_database(map_path))
            path = Path(folder) / f"db{attempt}.json"
            write_database(database, path)
            digests.append(hashlib.sha256(path.read_bytes()).hexdigest()[:16])
            print(f"build #{attempt + 1}: {len(database['spawn_points'])} spawn points in "
                  f"{build_s:.2f} s, sha256 {digests[-1]}")
        print(f"deterministic: {digests[0] == digests[1]}")

        raw = Path(folder) / "raw"
        write_highway_samples(raw / "highway", seed=7, per_class=args.records_per_class)
        write_urban_samples(raw / "urban", seed=7, per_class=args.records_per_class)
        params = [extract_params(item.record)
                  for item in iter_raw_records(raw, IngestReport())]
        matcher, load_s = _timed(lambda: SpawnMatcher(db_path, map_path))
    print(f"SpawnMatcher() load + schema check: {load_s:.2f} s")
    contexts = {entry["context"] for entry in matcher.entries}
    params = [p for p in params if p["domain"] in contexts]  # e.g. no highway on Town01
    matcher.assign(params[0], 0)  # first call loads the map's lane graph
    per_class: Counter = Counter()

    def assign_all():
        for p in params:
            matcher.assign(p, per_class[p["maneuver_class"]])
            per_class[p["maneuver_class"]] += 1

    _, assign_s = _timed(assign_all)
    _, find_s = _timed(lambda: [matcher.find(p, 5) for p in params])
    n = len(params)
    print(f"assign: {n} records in {assign_s:.2f} s = {1000 * assign_s / n:.2f} ms/record "
          f"({n / assign_s:.0f}/s); find alone {1000 * find_s / n:.2f} ms/record")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak RSS of this process: {peak:.0f} MB")


if __name__ == "__main__":
    main()

"""What a replay in esmini adds per scenario on one core, and where its time goes.

Target (issue "Speed"): replay adds at most 0.5 s per scenario (median, one core). The sample
data is made first (``scenweave sample-data --seed 7``'s generators), ``scenweave run --no-llm
--no-replay``'s Python equivalent turns it into scenario files, then a child process pinned to
one core replays each with ``player.replay_file`` (the way the run's replay stage does) and
reports the cost per scenario (median, p95, by domain) and its split: ``translate``,
``plan`` (choosing the roads), ``map`` (writing the cut copy), ``start`` (player process),
``load`` (esmini reading scenario and map), ``step``, ``collect``. The first replay of a
process also pays one-time costs (the player server, the map's road graph), shown apart.
``--whole-map`` replays on the whole map (no cut) for comparison.

With ``--jobs`` (``scenweave run --jobs N``, when the CLI has it) the whole run with replay
on is also timed for ``--jobs 1`` and ``--jobs 2``: scenarios per second.

    .venv/bin/python benchmarks/replay.py [--per-class 6] [--whole-map] [--cpu 0] [--jobs]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

SEED = 7
SPLIT = ("translate", "plan", "map", "start", "load", "step", "collect")
CLI = [sys.executable, "-m", "scenweave.cli"]


def make_scenarios(raw: Path, out: Path, per_class: int) -> list[Path]:
    """Sample data (seed 7) and ``scenweave run --no-llm --no-replay`` on it: the .xosc files."""
    from scenweave.ingest.samples import write_highway_samples, write_urban_samples
    from scenweave.inputs import InputSelection
    from scenweave.pipeline import PipelineSettings
    from scenweave.runner import run_batch

    write_highway_samples(raw / "highway", seed=SEED, per_class=per_class)
    write_urban_samples(raw / "urban", seed=SEED, per_class=per_class)
    result = run_batch(raw, out, InputSelection(), PipelineSettings(no_llm=True, replay=None),
                       run_id="bench")
    return sorted(result.folder.root.glob("*/scenario.xosc"))


def replay_all(files: list[Path], whole_map: bool) -> list[dict]:
    """Replay each file (this process should be pinned); one record per scenario."""
    from scenweave.player import ReplaySettings, replay_file
    from scenweave.roads import DEFAULT_MAP_PATH

    settings = ReplaySettings()
    if whole_map:
        settings = dataclasses.replace(settings, cut_map=False)
    records = []
    for path in files:
        started = time.perf_counter()
        playback = replay_file(path, DEFAULT_MAP_PATH, settings)
        wall = time.perf_counter() - started
        params = json.loads((path.parent / "params.json").read_text(encoding="utf-8"))
        records.append({"scenario": path.parent.name, "domain": params["domain"],
                        "wall_s": wall, "error": playback.engine_error,
                        "timings": playback.timings_s})
    return records


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summarize(records: list[dict]) -> None:
    """Print the figures: cost per scenario, by domain, its split, one-time costs."""
    first, rest = records[0], records[1:] or records
    walls = [r["wall_s"] for r in rest]
    print(f"replay cost per scenario ({len(rest)} scenarios, one core, first replay apart): "
          f"median {statistics.median(walls) * 1000:.0f} ms, p95 "
          f"{percentile(walls, 0.95) * 1000:.0f} ms, mean {statistics.fmean(walls) * 1000:.0f} "
          f"ms, max {max(walls) * 1000:.0f} ms (target median <= 500 ms: "
          f"{'met' if statistics.median(walls) <= 0.5 else 'MISSED'})")
    for domain in sorted({r["domain"] for r in rest}):
        chosen = [r["wall_s"] for r in rest if r["domain"] == domain]
        print(f"  {domain}: {len(chosen)} scenarios, median {statistics.median(chosen) * 1000:.0f}"
              f" ms, p95 {percentile(chosen, 0.95) * 1000:.0f} ms")
    print("split, median (p95) ms: " + ", ".join(
        f"{key} {statistics.median(v) * 1000:.1f} ({percentile(v, 0.95) * 1000:.1f})"
        for key in SPLIT
        if (v := [r["timings"].get(key, 0.0) for r in rest])))
    shares = [r["timings"]["map_share"] for r in rest if "map_share" in r["timings"]]
    kms = [r["timings"]["map_km"] for r in rest if "map_km" in r["timings"]]
    if shares:
        print(f"map loaded: median {statistics.median(kms):.2f} km = "
              f"{statistics.median(shares):.0%} of the map (p95 {percentile(shares, 0.95):.0%})")
    again = [r["scenario"] for r in rest if r["timings"].get("replays", 1) > 1]
    print(f"played again on the whole map (left the cut roads): {len(again)}"
          + (f" ({', '.join(again[:5])})" if again else ""))
    errors = [r for r in records if r["error"]]
    print(f"engine errors: {len(errors)}" + (f" (first: {errors[0]['error']})" if errors else ""))
    print(f"first replay of the process: {first['wall_s'] * 1000:.0f} ms (player server start, "
          "map graph and copies)")


def jobs_supported() -> bool:
    """Whether ``scenweave run`` has ``--jobs`` (another change adds it)."""
    help_text = subprocess.run([*CLI, "run", "--help"], capture_output=True, text=True,
                               cwd=ROOT).stdout
    return "--jobs" in help_text


def run_throughput(raw: Path, out: Path, jobs: int, cpus: list[int]) -> dict:
    """``scenweave run RAW --no-llm --jobs N`` with replay on, on ``cpus``: scenarios/s.

    Ready for the ``--jobs`` option of ``scenweave run``; the run's own start-up (imports,
    spawn database) is inside the wall time, as a user sees it.
    """
    pin = ["taskset", "-c", ",".join(map(str, cpus))] if Path("/usr/bin/taskset").exists() else []
    started = time.perf_counter()
    subprocess.run([*pin, *CLI, "run", str(raw), "--no-llm", "--replay", "--jobs", str(jobs),
                    "--out", str(out), "--run-id", f"jobs{jobs}", "--json"], check=True,
                   capture_output=True, text=True, cwd=ROOT)
    elapsed = time.perf_counter() - started
    summary = json.loads((out / f"jobs{jobs}" / "summary.json").read_text(encoding="utf-8"))
    return {"jobs": jobs, "scenarios": summary["total"], "elapsed_s": elapsed,
            "per_s": summary["total"] / elapsed, "counts": summary["counts"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=6,
                        help="sample records per class (17 classes)")
    parser.add_argument("--whole-map", action="store_true",
                        help="replay on the whole map (no cut), for comparison")
    parser.add_argument("--cpu", type=int, default=0, help="the core the replays run on")
    parser.add_argument("--jobs", action="store_true",
                        help="also time scenweave run --jobs 1 and --jobs 2 with replay on")
    parser.add_argument("--child", nargs=2, metavar=("FILES", "WHOLE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        os.sched_setaffinity(0, {args.cpu})  # the player server and its children inherit it
        files = [Path(p) for p in Path(args.child[0]).read_text().splitlines()]
        print(json.dumps(replay_all(files, args.child[1] == "1")))
        return
    with tempfile.TemporaryDirectory() as tmp:
        raw, out = Path(tmp) / "raw", Path(tmp) / "runs"
        files = make_scenarios(raw, out, args.per_class)
        listing = Path(tmp) / "files.txt"
        listing.write_text("\n".join(map(str, files)))
        child = subprocess.run([sys.executable, __file__, "--cpu", str(args.cpu), "--child",
                                str(listing), "1" if args.whole_map else "0"],
                               check=True, capture_output=True, text=True)
        records = json.loads(child.stdout.strip().splitlines()[-1])
        print(f"{'whole map' if args.whole_map else 'cut map'}, core {args.cpu}, "
              f"{len(files)} scenarios (seed {SEED}, {args.per_class} per class)")
        summarize(records)
        if args.jobs:
            if not jobs_supported():
                print("scenweave run --jobs: not available yet (run_throughput is ready)")
                return
            cores = sorted(os.sched_getaffinity(0))
            for jobs in (1, 2):
                result = run_throughput(raw, out, jobs, cores[:jobs])
                print(f"scenweave run --no-llm --jobs {jobs} with replay on {jobs} core(s): "
                      f"{result['scenarios']} scenarios in {result['elapsed_s']:.1f} s = "
                      f"{result['per_s']:.1f} scenarios/s ({result['counts']})")


if __name__ == "__main__":
    main()

"""Do the cores add up? Scenarios per second on one and two cores, locally and through the
queue, and where one scenario's time goes next to esmini alone.

On the seeded sample data (``scenweave sample-data --seed 7``, ``--per-class`` records of each
of the 17 classes), replay on, no LLM:

1. ``scenweave run --no-llm --jobs 1`` and ``--jobs 2``: wall time of the whole command as a
   user sees it (start-up, summary and report included), scenarios/s and the ratio
   (target: ``--jobs 2`` >= 1.8x ``--jobs 1`` on a 2-core machine).
2. The queue: a real ``redis-server`` on loopback, ``scenweave worker --workers 1`` and ``2``
   started and idle first, then ``scenweave submit --wait`` timed: submit, make, hand back,
   collect, summary and report.
3. The cost of one scenario (medians over the ``--jobs 1`` run's ``status.json``): spawn,
   generate (retrieve + reference script), XSD and checks (validation without the replay),
   replay load, replay steps, the rest of the replay (translate, cut map, start, collect),
   figure (drawn for the scenarios the report shows, mean over all), write (the commit:
   outcome written, folder renamed; timed by committing copies). Target: everything but the
   replay <= 25 % of the replay's cost.
4. Bare esmini: the same cut-map scenario as the replay hands esmini
   (``player.replay.esmini_input``) played by esmini's own command line, against
   ``player.replay_file`` of the same file in this process, interleaved, on ``--bare``
   scenarios. Target: replay <= 1.2x bare esmini.

    .venv/bin/python benchmarks/scale.py [--per-class 6] [--bare 20] [--no-queue]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.testing.redis_server import RedisServer  # noqa: E402

SEED = 7
CLI = [sys.executable, "-m", "scenweave.cli"]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def timed_run(raw: Path, out: Path, jobs: int) -> dict:
    """``scenweave run RAW --no-llm --jobs N``: seconds, scenarios/s and where the wall time
    went outside the scenarios (from the run folder's file times)."""
    started, wall_started = time.perf_counter(), time.time()
    subprocess.run([*CLI, "run", str(raw), "--no-llm", "--jobs", str(jobs), "--out", str(out),
                    "--run-id", f"jobs{jobs}"], env=ENV, cwd=ROOT, capture_output=True)
    elapsed = time.perf_counter() - started
    run = out / f"jobs{jobs}"
    total = json.loads((run / "summary.json").read_text())["total"]
    commits = sorted(p.stat().st_mtime for p in run.glob("*/status.json"))
    return {"elapsed_s": elapsed, "scenarios": total, "per_s": total / elapsed,
            "before_first_s": commits[0] - wall_started,
            "after_last_s": wall_started + elapsed - commits[-1]}


def _idle_workers(url: str) -> int:
    from redis import Redis
    from rq import Worker

    return sum(w.state == "idle" for w in Worker.all(connection=Redis.from_url(url)))


def timed_queue(raw: Path, out: Path, url: str, count: int, scratch: Path) -> dict:
    """``scenweave submit --wait`` with ``count`` idle workers: seconds and scenarios/s."""
    from redis import Redis

    Redis.from_url(url).flushall()
    log = scratch.with_suffix(".log")
    workers = subprocess.Popen([*CLI, "worker", "--queue", url, "--workers", str(count),
                                "--scratch", str(scratch)], env=ENV, cwd=ROOT,
                               stdout=log.open("w"), stderr=subprocess.STDOUT)
    try:
        while _idle_workers(url) < count:
            if workers.poll() is not None:
                raise RuntimeError(f"the workers stopped: {log.read_text()[-2000:]}")
            time.sleep(0.2)
        started = time.perf_counter()
        subprocess.run([*CLI, "submit", str(raw), "--no-llm", "--out", str(out), "--queue", url,
                        "--run-id", f"queue{count}", "--wait"], env=ENV, cwd=ROOT, check=True,
                       capture_output=True)
        elapsed = time.perf_counter() - started
    finally:
        workers.send_signal(signal.SIGTERM)
        workers.wait(timeout=120)
    total = json.loads((out / f"queue{count}" / "summary.json").read_text())["total"]
    # an infrastructure error (e.g. the player server not answering on a loaded machine) is
    # retried after --retry-delays 10,60,300 s: say so, it is in the wall time
    retried = sum("retry" in line.lower() for line in log.read_text().splitlines())
    return {"elapsed_s": elapsed, "scenarios": total, "per_s": total / elapsed,
            "retried": retried}


def cost_split(run: Path) -> dict[str, float]:
    """Median seconds per scenario of each stage (figure: mean over all scenarios)."""
    outcomes = [json.loads(p.read_text()) for p in sorted(run.glob("*/status.json"))]
    stages: dict[str, list[float]] = {}
    for o in outcomes:
        t, replay = o.get("timings_s") or {}, (o.get("replay") or {}).get("timings_s") or {}
        if not replay:
            continue
        add = stages.setdefault
        add("spawn", []).append(t.get("spawn", 0.0))
        add("generate", []).append(t.get("retrieve", 0.0) + t.get("generate", 0.0))
        add("XSD and checks", []).append(t.get("validate", 0.0) - replay.get("total", 0.0))
        add("replay load", []).append(replay.get("load", 0.0))
        add("replay steps", []).append(replay.get("step", 0.0))
        add("replay other", []).append(sum(replay.get(k, 0.0) for k in (
            "translate", "plan", "map", "start", "collect")))
    split = {name: statistics.median(values) for name, values in stages.items()}
    split["figure"] = sum((o.get("timings_s") or {}).get("figure", 0.0)
                          for o in outcomes) / len(outcomes)
    split["write"] = write_cost(run)
    return split


def write_cost(run: Path) -> float:
    """Median seconds to commit a scenario folder (outcome written, one rename), timed on
    copies of the run's folders."""
    from scenweave.run_folder import RunFolder

    copy = RunFolder(Path(tempfile.mkdtemp(prefix="scale-write-")))
    costs = []
    try:
        for folder in sorted(p.parent for p in run.glob("*/status.json")):
            outcome = json.loads((folder / "status.json").read_text())
            staging = copy.staging(folder.name)
            for path in folder.iterdir():
                if path.name != "status.json":
                    shutil.copyfile(path, staging / path.name)
            started = time.perf_counter()
            copy.commit(folder.name, staging, outcome)
            costs.append(time.perf_counter() - started)
    finally:
        shutil.rmtree(copy.root, ignore_errors=True)
    return statistics.median(costs)


def bare_esmini(run: Path, count: int) -> tuple[list[float], list[float]]:
    """(replay seconds, bare esmini seconds) of the first ``count`` scenarios, interleaved."""
    from scenweave.player import ReplaySettings, find_esmini, replay_file
    from scenweave.player.replay import esmini_input
    from scenweave.roads import DEFAULT_MAP_PATH

    binary = find_esmini().library.parent / "esmini"
    settings = ReplaySettings()
    files = sorted(run.glob("*/scenario.xosc"))[:count]
    replay_file(files[0], DEFAULT_MAP_PATH, settings)  # the process's one-time costs
    replays, bares = [], []
    with tempfile.TemporaryDirectory(prefix="scale-bare-") as tmp:
        for path in files:
            xml, until_s = esmini_input(path, DEFAULT_MAP_PATH, settings)
            prepared = Path(tmp) / "bare.xosc"
            prepared.write_bytes(xml)
            started = time.perf_counter()
            subprocess.run([str(binary), "--osc", str(prepared), "--headless",
                            "--fixed_timestep", str(settings.time_step_s), "--disable_log",
                            "--disable_stdout", "--collision"], cwd=tmp, capture_output=True)
            bares.append(time.perf_counter() - started)
            started = time.perf_counter()
            replay_file(path, DEFAULT_MAP_PATH, settings)
            replays.append(time.perf_counter() - started)
    return replays, bares


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=6, help="sample records per class")
    parser.add_argument("--bare", type=int, default=20, help="scenarios timed bare in esmini")
    parser.add_argument("--no-queue", action="store_true", help="skip the queue's timing")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on "
          f"{os.cpu_count()} cores")
    with tempfile.TemporaryDirectory(prefix="scale-") as tmp:
        raw, out = Path(tmp) / "raw", Path(tmp) / "runs"
        subprocess.run([*CLI, "sample-data", str(raw), "--seed", str(SEED), "--per-class",
                        str(args.per_class)], env=ENV, cwd=ROOT, check=True, capture_output=True)
        local = {jobs: timed_run(raw, out, jobs) for jobs in (1, 2)}
        for jobs, r in local.items():
            print(f"scenweave run --no-llm --jobs {jobs}: {r['scenarios']} scenarios in "
                  f"{r['elapsed_s']:.1f} s = {r['per_s']:.2f} scenarios/s; "
                  f"{r['before_first_s']:.1f} s to the first scenario, "
                  f"{r['after_last_s']:.1f} s after the last (summary, report)")
        ratio = local[2]["per_s"] / local[1]["per_s"]
        print(f"--jobs 2 / --jobs 1 = {ratio:.2f}x (target >= 1.8x: "
              f"{'met' if ratio >= 1.8 else 'MISSED'})")
        if not args.no_queue:
            server = RedisServer(Path(tmp) / "redis").start()
            try:
                for count in (1, 2):
                    r = timed_queue(raw, out, server.url, count, Path(tmp) / f"scratch{count}")
                    print(f"queue, {count} worker(s), submit --wait: {r['scenarios']} scenarios "
                          f"in {r['elapsed_s']:.1f} s = {r['per_s']:.2f} scenarios/s"
                          + (f" ({r['retried']} worker log lines about retries)"
                             if r["retried"] else ""))
            finally:
                server.stop()
        split = cost_split(out / "jobs1")
        replay = sum(v for k, v in split.items() if k.startswith("replay"))
        rest = sum(v for k, v in split.items() if not k.startswith("replay"))
        print("cost per scenario, --jobs 1 (median ms; figure: mean over all): " + ", ".join(
            f"{name} {seconds * 1000:.1f}" for name, seconds in split.items()))
        print(f"everything but the replay: {rest * 1000:.1f} ms = {rest / replay:.0%} of the "
              f"replay's {replay * 1000:.1f} ms (target <= 25%: "
              f"{'met' if rest <= 0.25 * replay else 'MISSED'})")
        replays, bares = bare_esmini(out / "jobs1", args.bare)
        r, b = statistics.median(replays), statistics.median(bares)
        print(f"same cut-map scenarios, {len(bares)}: replay_file median {r * 1000:.1f} ms, "
              f"bare esmini (command line) median {b * 1000:.1f} ms = {r / b:.2f}x "
              f"(target <= 1.2x: {'met' if r <= 1.2 * b else 'MISSED'})")
    load = os.getloadavg()
    print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


if __name__ == "__main__":
    main()

"""Do the cores add up? Scenarios per second for ``scenweave run --jobs N``, the serial part,
the replay in the batch against esmini alone, and memory (issue 33).

On the seeded sample data (``scenweave sample-data --seed 7``, ``--per-class`` records of each
of the 17 classes), replay on, no LLM:

1. ``scenweave run --no-llm --jobs N`` for each N of ``--jobs`` (default 1,2,4,8,16; N above
   the machine's cores is run and said so): wall time as a user sees it, scenarios/s and the
   speed-up over ``--jobs 1``; the serial part: *start* (the command's start until its first
   scenario was being made: the first commit's time less that scenario's own making), *end*
   (summary and report after the last commit), their share of the wall time. ``--jobs 1`` is
   also run on a third of the records: the serial part must not grow with the scenarios.
   Target: ``--jobs 2`` >= 1.9x ``--jobs 1`` on two cores; time to the first scenario <= 1 s.
2. Peak RSS (``VmHWM``) of the command (parent), of each worker it forks, of the player
   servers and of the player's per-scenario children, sampled from ``/proc`` during the run;
   the children's own peak comes from the replays (``timings_s.child_peak_rss_mb``).
   ``--memory 1000`` runs ``--jobs 2`` on 1,000 sample records for it.
3. The replay in the batch against esmini alone, interleaved: ``run_batch`` (the command's
   batch, one process) runs ``--paired`` records; after each scenario is made, the same
   cut-map file the replay played (``player.replay.esmini_input``) is played by esmini's own
   command line, and by ``player.replay_file`` outside the batch. Steady state (the first
   scenario, which starts the player, apart): median seconds of each, their ratios, and where
   the batch's replay time went. Target: in the batch <= 1.2x bare esmini.

The machine may be loaded by others: every figure is printed with the load average, and the
replay's comparison is a ratio measured interleaved, not an absolute.

    .venv/bin/python benchmarks/scale.py [--per-class 6] [--jobs 1,2,4,8,16] [--paired 34]
        [--memory 1000] [--no-queue]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.testing.redis_server import RedisServer  # noqa: E402

SEED = 7
CLI = [sys.executable, "-m", "scenweave.cli"]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def load_average() -> str:
    """The 1-minute load average and the cores, quoted next to every figure."""
    return f"load {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores"


class PeakMemory:
    """Peak RSS (``VmHWM``) of a process and every process under it, sampled from ``/proc``
    every ``interval_s`` while it runs, by role: ``parent``, ``worker`` (a fork of the parent),
    ``player server`` and ``player child`` (a scenario's esmini process)."""

    def __init__(self, pid: int, interval_s: float = 0.1) -> None:
        self.root, self.interval_s = pid, interval_s
        #: (pid, role) -> peak KiB: a fork is sampled as its parent's copy until it execs
        self.peaks: dict[tuple[int, str], int] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()

    def stop(self) -> dict[str, tuple[int, float]]:
        """Per role: how many processes were seen and the largest peak (MiB)."""
        self._stop.set()
        self._thread.join()
        roles: dict[str, list[int]] = {}
        for (_, role), kib in self.peaks.items():
            roles.setdefault(role, []).append(kib)
        return {role: (len(kibs), max(kibs) / 1024) for role, kibs in roles.items()}

    def _sample(self) -> None:
        while not self._stop.is_set():
            for pid, role in self._tree():
                kib = _status_kib(pid, "VmHWM")
                if kib is not None:
                    self.peaks[(pid, role)] = max(kib, self.peaks.get((pid, role), 0))
            self._stop.wait(self.interval_s)

    def _tree(self) -> list[tuple[int, str]]:
        found, todo = [], [(self.root, "parent")]
        while todo:
            pid, role = todo.pop()
            found.append((pid, role))
            for child in _children(pid):
                serves = "engine import serve" in _cmdline(child)
                todo.append((child, "player child" if role.startswith("player") else
                             "player server" if serves else "worker"))
        return found


def _children(pid: int) -> list[int]:
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
        return [int(c) for task in tasks for c in (task / "children").read_text().split()]
    except OSError:
        return []


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _status_kib(pid: int, key: str) -> int | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1])
    except (OSError, ValueError):
        pass
    return None


def timed_run(raw: Path, out: Path, jobs: int, run_id: str) -> dict:
    """``scenweave run RAW --no-llm --jobs N``: seconds, scenarios/s, the serial part (start:
    until the first scenario was being made; end: after the last commit) and peak RSS."""
    started, wall_started = time.perf_counter(), time.time()
    process = subprocess.Popen([*CLI, "run", str(raw), "--no-llm", "--jobs", str(jobs), "--out",
                                str(out), "--run-id", run_id], env=ENV, cwd=ROOT,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    memory = PeakMemory(process.pid)
    process.wait()
    elapsed = time.perf_counter() - started
    peaks = memory.stop()
    run = out / run_id
    total = json.loads((run / "summary.json").read_text())["total"]
    outcomes = sorted(((p.stat().st_mtime, json.loads(p.read_text()))
                       for p in run.glob("*/status.json")), key=lambda pair: pair[0])
    first_at, first = outcomes[0]
    timings = first.get("timings_s") or {}
    making = timings.get("total", 0.0) + timings.get("figure", 0.0)
    children = [(o.get("replay") or {}).get("timings_s", {}).get("child_peak_rss_mb", 0.0)
                for _, o in outcomes]
    if any(children):
        peaks["player child"] = (len(children), max(children))
    return {"elapsed_s": elapsed, "scenarios": total, "per_s": total / elapsed,
            "first_s": first_at - wall_started, "start_s": first_at - wall_started - making,
            "end_s": wall_started + elapsed - outcomes[-1][0], "peaks": peaks,
            "load": load_average()}


def print_run(jobs: int, r: dict, base: dict | None) -> None:
    """One ``--jobs N`` run's line: rate, speed-up, serial part, memory."""
    cores = os.cpu_count() or 1
    speedup = f" = {r['per_s'] / base['per_s']:.2f}x --jobs 1" if base else ""
    over = f" (N > {cores} cores: more processes than cores)" if jobs > cores else ""
    serial = r["start_s"] + r["end_s"]
    print(f"--jobs {jobs}{over}: {r['scenarios']} scenarios in {r['elapsed_s']:.1f} s = "
          f"{r['per_s']:.2f} scenarios/s{speedup}; first scenario committed after "
          f"{r['first_s']:.2f} s; serial: start {r['start_s']:.2f} s + end (summary, report) "
          f"{r['end_s']:.2f} s = {serial / r['elapsed_s']:.0%} of the wall time ({r['load']})")
    print("    peak RSS (MiB, largest of each kind): " + ", ".join(
        f"{role} {mib:.0f} (of {count})" for role, (count, mib) in sorted(r["peaks"].items())))


def start_cpu(raw: Path, out: Path) -> dict[str, float]:
    """The start in CPU seconds, which a loaded machine hardly changes (wall time it does):
    ``scenweave run RAW --no-llm --limit 1`` with ``python -X importtime``: the CPU of the
    command and every process it waited for (its player server and the scenario's child),
    the wall time, and the imports' time (every module's self time summed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-X", "importtime", *CLI[1:], "run", str(raw),
                           "--no-llm", "--limit", "1", "--out", str(out), "--run-id", "start"],
                          env=ENV, cwd=ROOT, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    imports_us = sum(int(line.split("|")[0].split(":")[1]) for line in done.stderr.splitlines()
                     if line.startswith("import time:") and "self" not in line)
    return {"wall_s": wall, "imports_s": imports_us / 1e6,
            "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)}


def print_start_cpu(r: dict[str, float]) -> None:
    """The start's CPU line (a run of one record, its own first scenario included)."""
    print(f"start, one record (run --limit 1, its scenario, summary and report included): "
          f"{r['cpu_s']:.2f} s CPU, of which imports {r['imports_s']:.2f} s "
          f"(-X importtime: each module's own time summed, a wall clock, so a loaded machine "
          f"stretches it); {r['wall_s']:.2f} s wall ({load_average()})")


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


def paired_in_batch(raw: Path, out: Path) -> list[dict[str, Any]]:
    """``run_batch`` on ``raw`` in this process (the command's batch, ``--jobs 1``); after
    each scenario is made, its cut-map file played by esmini's command line and by
    ``replay_file``, interleaved with the batch: per scenario, the three wall times (s) and
    the batch replay's split."""
    from scenweave import runner
    from scenweave.inputs import InputSelection
    from scenweave.pipeline import PipelineSettings
    from scenweave.player import ReplaySettings, replay_file
    from scenweave.roads import DEFAULT_MAP_PATH

    settings = ReplaySettings()
    rows: list[dict[str, Any]] = []
    make: Callable[..., dict] = runner.make_scenario

    def make_and_compare(params: Any, index: int, staging: Path, *rest: Any) -> dict:
        outcome = make(params, index, staging, *rest)
        replay = (outcome.get("replay") or {}).get("timings_s") or {}
        xosc = staging / "scenario.xosc"
        if replay and xosc.is_file():
            bare = bare_esmini(xosc, DEFAULT_MAP_PATH, settings)
            started = time.perf_counter()
            replay_file(xosc, DEFAULT_MAP_PATH, settings)
            rows.append({"batch": replay["total"], "bare": bare,
                         "replay_file": time.perf_counter() - started, "split": replay})
        return outcome

    runner.make_scenario = make_and_compare  # type: ignore[assignment]
    try:
        runner.run_batch(raw, out, InputSelection(),
                         PipelineSettings(no_llm=True, replay=settings), run_id="paired")
    finally:
        runner.make_scenario = make  # type: ignore[assignment]
    return rows


def bare_esmini(xosc: Path, map_path: Path, settings: Any) -> float:
    """Seconds esmini's own command line takes to play the cut-map file the replay played."""
    from scenweave.player import find_esmini
    from scenweave.player.replay import esmini_input

    binary = find_esmini().library.parent / "esmini"
    xml, _ = esmini_input(xosc, map_path, settings)  # the copy the replay wrote, cached
    with tempfile.TemporaryDirectory(prefix="scale-bare-") as tmp:
        prepared = Path(tmp) / "bare.xosc"
        prepared.write_bytes(xml)
        started = time.perf_counter()
        done = subprocess.run([str(binary), "--osc", str(prepared), "--headless",
                               "--fixed_timestep", str(settings.time_step_s), "--disable_log",
                               "--disable_stdout", "--collision"], cwd=tmp, capture_output=True)
        elapsed = time.perf_counter() - started
    if done.returncode != 0:  # a quick failure is no time to compare with
        raise RuntimeError(f"bare esmini failed on {xosc} (exit {done.returncode}): "
                           f"{done.stderr.decode(errors='replace')[-500:]}")
    return elapsed


#: a replay's split (``collect``: ``close`` + ``pack`` + ``transfer``, one figure in older code)
SPLIT = ("translate", "plan", "map", "start", "load", "step", "collect", "close", "pack",
         "transfer")


def print_paired(rows: list[dict[str, Any]]) -> None:
    """Steady state (the first scenario apart): medians, ratios, the batch replay's split."""
    steady = rows[1:] or rows
    mean = {k: statistics.fmean(r[k] for r in steady) for k in ("batch", "bare", "replay_file")}
    ratios = [r["batch"] / r["bare"] for r in steady]
    ratio = mean["batch"] / mean["bare"]
    print(f"replay of the same cut-map file, {len(steady)} scenarios interleaved, steady state: "
          f"in the batch {mean['batch'] * 1000:.1f} ms, replay_file "
          f"{mean['replay_file'] * 1000:.1f} ms, bare esmini (command line) "
          f"{mean['bare'] * 1000:.1f} ms (means); in the batch / bare = {ratio:.2f}x (per "
          f"scenario: median {statistics.median(ratios):.2f}x, p90 "
          f"{sorted(ratios)[int(0.9 * (len(ratios) - 1))]:.2f}x; target <= 1.2x: "
          f"{'met' if ratio <= 1.2 else 'MISSED'}) ({load_average()})")
    print("    the batch's replay, median ms: " + ", ".join(
        f"{key} {statistics.median(r['split'].get(key, 0.0) for r in steady) * 1000:.1f}"
        for key in SPLIT) + f"; first scenario {rows[0]['batch'] * 1000:.0f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=6, help="sample records per class")
    parser.add_argument("--jobs", default="1,2,4,8,16", help="the --jobs values to time")
    parser.add_argument("--paired", type=int, default=2,
                        help="records per class replayed in the batch beside bare esmini")
    parser.add_argument("--memory", type=int, default=0,
                        help="also run --jobs 2 on this many sample records for peak RSS")
    parser.add_argument("--no-queue", action="store_true", help="skip the queue's timing")
    args = parser.parse_args()
    print(f"before: {load_average()}")
    with tempfile.TemporaryDirectory(prefix="scale-") as tmp:
        out = Path(tmp) / "runs"
        raw = sample_data(Path(tmp) / "raw", args.per_class)
        # first, so the timed runs after it all find the files in the page cache: the first
        # of them started 0.4 s later than the rest for it (17 records 1.26 s, 34 1.69 s)
        print_start_cpu(start_cpu(raw, out))
        runs: dict[int, dict] = {}
        for jobs in [int(n) for n in args.jobs.split(",")]:
            runs[jobs] = timed_run(raw, out, jobs, f"jobs{jobs}")
            print_run(jobs, runs[jobs], runs.get(1) if jobs != 1 else None)
        if 1 in runs and 2 in runs:
            ratio = runs[2]["per_s"] / runs[1]["per_s"]
            print(f"--jobs 2 / --jobs 1 = {ratio:.2f}x (target >= 1.9x: "
                  f"{'met' if ratio >= 1.9 else 'MISSED'}); time to the first scenario "
                  f"{runs[1]['first_s']:.2f} s (target <= 1 s: "
                  f"{'met' if runs[1]['first_s'] <= 1 else 'MISSED'})")
        small = sample_data(Path(tmp) / "small", max(1, args.per_class // 3))
        fewer = timed_run(small, out, 1, "small")
        print_run(1, fewer, None)
        print(f"serial part with {fewer['scenarios']} and with {runs.get(1, fewer)['scenarios']} "
              f"scenarios (--jobs 1): start {fewer['start_s']:.2f} / "
              f"{runs.get(1, fewer)['start_s']:.2f} s, end {fewer['end_s']:.2f} / "
              f"{runs.get(1, fewer)['end_s']:.2f} s")
        if not args.no_queue:
            time_queue(raw, out, Path(tmp))
        if 1 in runs:
            split = cost_split(out / "jobs1")
            print("cost per scenario, --jobs 1 (median ms; figure: mean over all): " + ", ".join(
                f"{name} {seconds * 1000:.1f}" for name, seconds in split.items()))
        paired = sample_data(Path(tmp) / "paired", args.paired)
        print_paired(paired_in_batch(paired, out))
        if args.memory:
            many = sample_data(Path(tmp) / "many", math.ceil(args.memory / 17))
            r = timed_run(many, out, 2, "memory")
            print(f"memory, {r['scenarios']} records:")
            print_run(2, r, None)
    print(f"after: {load_average()}")


def sample_data(raw: Path, per_class: int) -> Path:
    """``scenweave sample-data RAW --seed 7 --per-class N`` (17 classes)."""
    subprocess.run([*CLI, "sample-data", str(raw), "--seed", str(SEED), "--per-class",
                    str(per_class)], env=ENV, cwd=ROOT, check=True, capture_output=True)
    return raw


def time_queue(raw: Path, out: Path, tmp: Path) -> None:
    """The queue with one and two workers (``submit --wait``)."""
    server = RedisServer(tmp / "redis").start()
    try:
        for count in (1, 2):
            r = timed_queue(raw, out, server.url, count, tmp / f"scratch{count}")
            print(f"queue, {count} worker(s), submit --wait: {r['scenarios']} scenarios "
                  f"in {r['elapsed_s']:.1f} s = {r['per_s']:.2f} scenarios/s"
                  + (f" ({r['retried']} worker log lines about retries)"
                     if r["retried"] else "") + f" ({load_average()})")
    finally:
        server.stop()


if __name__ == "__main__":
    main()

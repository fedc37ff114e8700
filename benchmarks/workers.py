"""Throughput of the queue with 1, 2 and 4 workers when the slow part is the LLM server.

Each scenario waits a fixed latency (default 1000 ms) in a stand-in for the LLM call — the
real Town04 matcher behind a sleep — then runs the real reference script and validation, so
the workers share the machine's CPU for the rest as they would on the GPU host. A real
``redis-server`` on loopback, real ``scenweave submit`` and ``scenweave worker --workers N``
processes; the clock runs from the submit until the last scenario is committed (workers
are started and idle beforehand, so their start-up is not counted).

    .venv/bin/python benchmarks/workers.py [--latency-ms 1000] [--per-class 8] [--workers 1,2,4]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

LATENCY_ENV = "SCENWEAVE_STANDIN_LATENCY_MS"
CLASSES = ("BRAKE", "LCF", "U4_1")


class StandInLLMMatcher:
    """The real SpawnMatcher after a fixed sleep: an LLM server answering in fixed time."""

    def __init__(self) -> None:
        from spawn_db import SpawnMatcher

        self.inner = SpawnMatcher()
        self.latency_s = float(os.environ.get(LATENCY_ENV, "1000")) / 1000

    def assign(self, params: dict, index: int, top_n: int = 5) -> dict:
        time.sleep(self.latency_s)
        return self.inner.assign(params, index, top_n=top_n)


def _idle_workers(url: str) -> int:
    from redis import Redis
    from rq import Worker

    return sum(w.state == "idle" for w in Worker.all(connection=Redis.from_url(url)))


def measure(count: int, url: str, data: Path, out: Path, latency_ms: int) -> dict:
    """Seconds from submit to the last commit of a run done by ``count`` workers."""
    from redis import Redis

    Redis.from_url(url).flushall()
    env = {**os.environ, LATENCY_ENV: str(latency_ms),
           "PYTHONPATH": f"{ROOT / 'benchmarks'}{os.pathsep}{ROOT}"}
    cli = [sys.executable, "-m", "scenweave.cli"]
    workers = subprocess.Popen([*cli, "worker", "--queue", url, "--workers", str(count),
                                "--preload", "workers:StandInLLMMatcher"], env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while _idle_workers(url) < count:
            time.sleep(0.2)
        run_id = f"w{count}"
        started = time.perf_counter()
        subprocess.run([*cli, "submit", str(data), "--no-llm", "--out", str(out), "--queue", url,
                        "--run-id", run_id, "--classes", ",".join(CLASSES),
                        "--matcher", "workers:StandInLLMMatcher"], env=env, check=True,
                       stdout=subprocess.DEVNULL)
        run = out / run_id
        expected = _expected(run)
        while len(list(run.glob("*/status.json"))) < expected or not (run / "report.html").exists():
            time.sleep(0.05)
        elapsed = time.perf_counter() - started
    finally:
        workers.send_signal(signal.SIGTERM)
        workers.wait(timeout=60)
    return {"workers": count, "scenarios": expected, "seconds": elapsed}


def _expected(run: Path) -> int:
    import json

    return json.loads((run / "run.json").read_text())["scenarios"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--latency-ms", type=int, default=1000)
    parser.add_argument("--per-class", type=int, default=8)
    parser.add_argument("--workers", default="1,2,4")
    args = parser.parse_args()

    from ingest.samples import write_highway_samples, write_urban_samples
    from tests.worker.redis_server import RedisServer

    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = Path(tmp)
        write_highway_samples(tmp_path / "data" / "highway", seed=7, per_class=args.per_class)
        write_urban_samples(tmp_path / "data" / "urban", seed=7, per_class=args.per_class)
        server = RedisServer(tmp_path / "redis").start()
        try:
            rows = [measure(int(n), server.url, tmp_path / "data", tmp_path / "runs",
                            args.latency_ms) for n in args.workers.split(",")]
        finally:
            server.stop()
    print(f"queue throughput, LLM stand-in {args.latency_ms} ms/scenario, "
          f"{rows[0]['scenarios']} scenarios ({', '.join(CLASSES)}), {os.cpu_count()} cores")
    print(f"{'workers':>8} {'seconds':>8} {'scen/min':>9} {'speed-up':>9} {'ideal':>6}")
    for row in rows:
        per_min = 60 * row["scenarios"] / row["seconds"]
        print(f"{row['workers']:>8} {row['seconds']:>8.1f} {per_min:>9.1f} "
              f"{rows[0]['seconds'] / row['seconds']:>9.2f} "
              f"{row['workers'] / rows[0]['workers']:>6.0f}")


if __name__ == "__main__":
    main()

"""Throughput of the queue with 1, 2 and 4 workers when the slow part is the LLM server.

The LLM server is a stand-in: a real HTTP server on loopback speaking Ollama's API
(``scenweave.testing.fake_ollama``) that answers every chat after a fixed latency (default
1000 ms) and serves requests in parallel, as an Ollama server with several slots would. The
workers run the real agent on it (``--llm ollama --repair patch``; the stand-in answers
``NO CHANGES``, so each scenario is the reference script, run in the real sandbox and
validated), with a real ``redis-server`` on loopback and real ``scenweave submit`` and
``scenweave worker --workers N`` processes. The clock runs from the submit until the last
scenario is committed and the report written by ``submit --wait`` (workers are started and
idle beforehand, so their start-up is not counted).

    .venv/bin/python benchmarks/workers.py [--latency-ms 1000] [--per-class 4] [--workers 1,2,4]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave.testing.fake_ollama import FakeOllama  # noqa: E402
from scenweave.testing.redis_server import RedisServer  # noqa: E402

CLASSES = ("BRAKE", "LCF", "U4_1")
CLI = [sys.executable, "-m", "scenweave.cli"]


def _idle_workers(url: str) -> int:
    from redis import Redis
    from rq import Worker

    return sum(w.state == "idle" for w in Worker.all(connection=Redis.from_url(url)))


def measure(count: int, url: str, llm: FakeOllama, data: Path, out: Path, env: dict,
            sandbox: str) -> dict:
    """Seconds from submit to the last commit of a run done by ``count`` workers."""
    from redis import Redis

    Redis.from_url(url).flushall()
    workers = subprocess.Popen([*CLI, "worker", "--queue", url, "--workers", str(count)],
                               env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while _idle_workers(url) < count:
            time.sleep(0.2)
        run_id, chats_before = f"w{count}", len(llm.requests)
        started = time.perf_counter()
        subprocess.run([*CLI, "submit", str(data), "--out", str(out), "--queue", url,
                        "--run-id", run_id, "--classes", ",".join(CLASSES), "--llm", "ollama",
                        "--ollama-host", llm.url, "--repair", "patch", "--sandbox", sandbox,
                        "--wait"], env=env, check=True, stdout=subprocess.DEVNULL)
        elapsed = time.perf_counter() - started
        run = out / run_id
        expected = json.loads((run / "run.json").read_text())["scenarios"]
    finally:
        workers.send_signal(signal.SIGTERM)
        workers.wait(timeout=60)
    counts = json.loads((run / "summary.json").read_text())["counts"]
    chats = sum(path == "/api/chat" for path, _ in llm.requests[chats_before:])
    return {"workers": count, "scenarios": expected, "seconds": elapsed, "ok": counts["ok"],
            "chats": chats}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--latency-ms", type=int, default=1000)
    parser.add_argument("--per-class", type=int, default=4)
    parser.add_argument("--workers", default="1,2,4")
    parser.add_argument("--sandbox", default="auto", choices=("auto", "docker", "bwrap"))
    args = parser.parse_args()

    from scenweave.ingest.samples import write_highway_samples, write_urban_samples

    with tempfile.TemporaryDirectory() as tmp, \
            FakeOllama(reply="NO CHANGES", delay_s=args.latency_ms / 1000) as llm:
        tmp_path = Path(tmp)
        write_highway_samples(tmp_path / "data" / "highway", seed=7, per_class=args.per_class)
        write_urban_samples(tmp_path / "data" / "urban", seed=7, per_class=args.per_class)
        env = {**os.environ, "SCENWEAVE_HOME": str(tmp_path / "home")}
        server = RedisServer(tmp_path / "redis").start()
        try:
            rows = [measure(int(n), server.url, llm, tmp_path / "data", tmp_path / "runs", env,
                            args.sandbox) for n in args.workers.split(",")]
        finally:
            server.stop()
    print(f"queue throughput, agent on an Ollama stand-in answering in {args.latency_ms} ms, "
          f"{rows[0]['scenarios']} scenarios ({', '.join(CLASSES)}), {os.cpu_count()} cores")
    print(f"{'workers':>8} {'seconds':>8} {'scen/min':>9} {'speed-up':>9} {'ideal':>6} "
          f"{'ok':>4} {'chats':>6}")
    for row in rows:
        per_min = 60 * row["scenarios"] / row["seconds"]
        print(f"{row['workers']:>8} {row['seconds']:>8.1f} {per_min:>9.1f} "
              f"{rows[0]['seconds'] / row['seconds']:>9.2f} "
              f"{row['workers'] / rows[0]['workers']:>6.0f} {row['ok']:>4} {row['chats']:>6}")


if __name__ == "__main__":
    main()

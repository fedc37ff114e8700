"""What one benign attempt costs in the sandbox: the wall time of ``run()`` per backend, split.

The attempt is the BRAKE reference script (imports scenariogeneration through the scenario
library, builds and writes a real scenario). Two ways of running it:

- cold: every attempt starts a fresh bwrap sandbox or container and imports inside it;
- warm: what a batch pays (``agent``'s sandbox keeps ``AgentSettings.sandbox.warm_pool``
  sandboxes started ahead, the interpreter up and scenariogeneration imported, still one
  sandbox per attempt). The benchmark pauses between attempts as the LLM's turn would, so
  the pool has refilled.

The split (medians, from ``ExecResult.timings``): start (until the job begins inside),
import (scenariogeneration and the scenario library, inside), generate (the script), collect
(outputs listed inside, vetted and written on the host), stop (report, exit, teardown). Targets for
what a batch pays per attempt: <= 0.5 s with bwrap, <= 1.0 s with docker. Starts a podman
service of its own when no engine answers.

    .venv/bin/python benchmarks/sandbox.py [--runs 10] [--backend bwrap --backend docker]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

TARGET_S = {"bwrap": 0.5, "docker": 1.0}
PHASES = ("start", "import", "generate", "collect", "stop")
#: a batch's pause between attempts (the LLM writing the next one), long enough for the pool
#: to start a sandbox and import in it
REFILL_PAUSE_S = {"bwrap": 2.0, "docker": 4.0}


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def _measure(box, code: str, params: dict, runs: int, pause_s: float) -> dict[str, list[float]]:
    figures: dict[str, list[float]] = {"run": [], **{phase: [] for phase in PHASES}}
    for _ in range(runs):
        time.sleep(pause_s)
        with tempfile.TemporaryDirectory() as out:
            began = time.perf_counter()
            result = box.run(code, params, Path(out))
            figures["run"].append(time.perf_counter() - began)
        if not result.ok:
            raise SystemExit(f"{box.name}: benchmark script failed: {result.error_type}: "
                             f"{result.error_message}\n{result.traceback or result.stderr}")
        for phase in PHASES:
            figures[phase].append(result.timings[phase])
    return figures


def _engine(backend: str, stack: contextlib.ExitStack) -> str | None:
    if backend != "docker":
        return None
    from scenweave.sandbox import SandboxSettings
    from scenweave.sandbox.engine import engine_answers, start_podman_service

    url = SandboxSettings().engine_url()
    if engine_answers(url):
        return url
    socket = Path(tempfile.mkdtemp(prefix="scenweave-bench-")) / "podman.sock"
    service = start_podman_service(socket)
    stack.callback(service.wait)
    stack.callback(service.terminate)
    return f"unix://{socket}"


def _print(backend: str, mode: str, figures: dict[str, list[float]]) -> None:
    run = figures["run"]
    split = "  ".join(f"{phase} {statistics.median(figures[phase]):.3f}" for phase in PHASES)
    verdict = ""
    if mode == "warm":
        met = statistics.median(run) <= TARGET_S[backend]
        verdict = f"   ({'meets' if met else 'MISSES'} the batch target {TARGET_S[backend]} s)"
    print(f"{backend:6} {mode}  run() {statistics.median(run):.3f} / {_percentile(run, .9):.3f}"
          f"   split: {split}{verdict}")


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--backend", action="append", choices=["bwrap", "docker"])
    args = parser.parse_args()

    from scenweave.agent.settings import AgentSettings
    from scenweave.corpus import list_scripts
    from scenweave.sandbox import SandboxSettings, get_sandbox
    from tests.corpus.params_examples import example_params

    brake = next(p for p in list_scripts() if p.name == "gen_hw_brake.py").read_text()
    batch_pool = AgentSettings().sandbox.warm_pool
    print(f"gen_hw_brake.py, {args.runs} attempts per line; seconds; run() p50 / p90, split "
          f"p50; warm = a batch's pool of {batch_pool}")
    for backend in args.backend or ["bwrap", "docker"]:
        with contextlib.ExitStack() as stack:
            engine = _engine(backend, stack)
            for mode, pool, pause_s in (("cold", 0, 0.0),
                                        ("warm", batch_pool, REFILL_PAUSE_S[backend])):
                settings = SandboxSettings(backend=backend, docker_host=engine, warm_pool=pool)
                with get_sandbox(settings) as box:
                    _measure(box, brake, example_params("BRAKE"), 1, pause_s)  # warm-up
                    _print(backend, mode, _measure(box, brake, example_params("BRAKE"),
                                                   args.runs, pause_s))


if __name__ == "__main__":
    main()

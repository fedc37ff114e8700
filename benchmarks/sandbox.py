"""Sandbox overhead per attempt: wall time minus the script's own time, per backend.

Cold: each attempt starts a fresh bwrap sandbox or container. Warm: a pool of one sandbox
started ahead (interpreter up, scenariogeneration imported), still one sandbox per attempt;
the benchmark waits for the refill between attempts, so the figures are per attempt. Two
scripts: a trivial one (pure sandbox cost) and the BRAKE reference script (imports
scenariogeneration, builds and writes a real scenario). Targets: p50 overhead <= 0.3 s for
bwrap and <= 1.0 s for docker. Starts a podman service of its own when no engine answers.

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

TRIVIAL = "def generate(params, out_path):\n    open(out_path, 'w').write('<x/>')\n"
TARGET_P50_S = {"bwrap": 0.3, "docker": 1.0}
WARM_REFILL_S = 3.0  # time a warm sandbox needs to start and import before the next attempt


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def _measure(box, code: str, params: dict, runs: int, pause_s: float) -> dict[str, list[float]]:
    figures: dict[str, list[float]] = {"wall": [], "script": [], "overhead": []}
    for _ in range(runs):
        time.sleep(pause_s)
        with tempfile.TemporaryDirectory() as out:
            result = box.run(code, params, Path(out))
        if not result.ok:
            raise SystemExit(f"{box.name}: benchmark script failed: {result.error_type}: "
                             f"{result.error_message}\n{result.traceback or result.stderr}")
        figures["wall"].append(result.duration_s)
        figures["script"].append(result.script_duration_s)
        figures["overhead"].append(result.overhead_s)
    return figures


def _engine(backend: str, stack) -> str | None:
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


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--backend", action="append", choices=["bwrap", "docker"])
    args = parser.parse_args()

    from scenweave.corpus import list_scripts
    from scenweave.sandbox import SandboxSettings, get_sandbox
    from tests.corpus.params_examples import example_params

    brake = next(p for p in list_scripts() if p.name == "gen_hw_brake.py").read_text()
    cases = [("trivial", TRIVIAL, {}), ("gen_hw_brake", brake, example_params("BRAKE"))]
    print(f"{args.runs} attempts per case; seconds; p50 / p90")
    for backend in args.backend or ["bwrap", "docker"]:
        with contextlib.ExitStack() as stack:
            engine = _engine(backend, stack)
            for mode, pool, pause_s in (("cold", 0, 0.0), ("warm", 1, WARM_REFILL_S)):
                settings = SandboxSettings(backend=backend, docker_host=engine, warm_pool=pool)
                with get_sandbox(settings) as box:
                    box.run(TRIVIAL, {}, Path(stack.enter_context(tempfile.TemporaryDirectory())))
                    for name, code, params in cases:
                        figures = _measure(box, code, params, args.runs, pause_s)
                        _print(backend, mode, name, figures)


def _print(backend: str, mode: str, name: str, figures: dict[str, list[float]]) -> None:
    line = "  ".join(f"{key} {_percentile(v, .5):.3f} / {_percentile(v, .9):.3f}"
                     for key, v in figures.items())
    p50 = statistics.median(figures["overhead"])
    verdict = "meets" if p50 <= TARGET_P50_S[backend] else "MISSES"
    print(f"{backend:6} {mode} {name:12} {line}   ({verdict} p50 overhead target "
          f"{TARGET_P50_S[backend]} s)")


if __name__ == "__main__":
    main()

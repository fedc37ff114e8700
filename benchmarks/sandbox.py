"""Sandbox overhead per attempt: wall time minus the script's own time, per backend.

Every attempt is cold (a fresh bwrap sandbox or a fresh container; there is no pool).
Two scripts: a trivial one (pure sandbox cost) and the BRAKE reference script (imports
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
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

TRIVIAL = "def generate(params, out_path):\n    open(out_path, 'w').write('<x/>')\n"
TARGET_P50_S = {"bwrap": 0.3, "docker": 1.0}


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def _measure(box, code: str, params: dict, runs: int) -> dict[str, list[float]]:
    figures: dict[str, list[float]] = {"wall": [], "script": [], "overhead": []}
    for _ in range(runs):
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
    from sandbox import SandboxSettings
    from sandbox.engine import engine_answers, start_podman_service

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

    from corpus import list_scripts
    from sandbox import SandboxSettings, get_sandbox
    from tests.corpus.params_examples import example_params

    brake = next(p for p in list_scripts() if p.name == "gen_hw_brake.py").read_text()
    cases = [("trivial", TRIVIAL, {}), ("gen_hw_brake", brake, example_params("BRAKE"))]
    print(f"{args.runs} cold attempts per case; seconds; p50 / p90")
    for backend in args.backend or ["bwrap", "docker"]:
        with contextlib.ExitStack() as stack:
            settings = SandboxSettings(backend=backend, docker_host=_engine(backend, stack))
            box = get_sandbox(settings)
            stack.callback(box.close)
            box.run(TRIVIAL, {}, Path(stack.enter_context(tempfile.TemporaryDirectory())))
            for name, code, params in cases:
                figures = _measure(box, code, params, args.runs)
                line = "  ".join(f"{key} {_percentile(v, .5):.3f} / {_percentile(v, .9):.3f}"
                                 for key, v in figures.items())
                p50 = statistics.median(figures["overhead"])
                verdict = "meets" if p50 <= TARGET_P50_S[backend] else "MISSES"
                print(f"{backend:6} {name:12} {line}   ({verdict} p50 overhead target "
                      f"{TARGET_P50_S[backend]} s)")


if __name__ == "__main__":
    main()

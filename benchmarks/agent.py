"""What the agent with the embedded model reaches on the sample data: success (ok or
repaired), first-attempt success and fallback rate per class and per strategy, with output
tokens and wall time per scenario, for the whole-script strategy (thesis, ``error_feedback``)
and the ``patch`` strategy (JSON line edits held to a grammar).

The same seeded sample records go through each strategy (one record per class of
``--classes``); the LLM log is switched off so only the agent is measured. Prints one table
row per strategy and a JSON line per scenario with ``--verbose``.

    .venv/bin/python benchmarks/agent.py [--classes BRAKE,CINF,LCF,U4_1,U1_1] [--repairs ...]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

STRATEGY_LABELS = {"error_feedback": "whole script (error-feedback)",
                   "patch": "patch (edit blocks)", "code_corrections": "code-corrections"}


def run_strategy(raw: Path, out: Path, classes: tuple[str, ...], repair: str,
                 max_attempts: int, sandbox: str) -> tuple[list[dict], float]:
    """All selected records through the agent with ``repair``; outcomes and wall time."""
    from scenweave.agent import AgentSettings
    from scenweave.agent.settings import batch_sandbox
    from scenweave.inputs import InputSelection
    from scenweave.pipeline import PipelineSettings
    from scenweave.runner import run_batch

    settings = PipelineSettings(no_llm=False, agent=AgentSettings(
        llm="embedded", repair=repair, max_attempts=max_attempts,
        sandbox=batch_sandbox(sandbox)))
    started = time.perf_counter()
    result = run_batch(raw, out, InputSelection(classes=classes, per_class=1), settings,
                       run_id=repair)
    return result.summary["scenarios"], time.perf_counter() - started


def llm_calls(outcomes: list[dict], run_dir: Path) -> list[dict]:
    """Every generate/repair event that asked the LLM, from the scenarios' traces."""
    from scenweave.run_folder import safe_name

    calls = []
    for o in outcomes:
        trace = run_dir / safe_name(o["scenario_id"]) / "trace.jsonl"
        for line in trace.read_text().splitlines():
            event = json.loads(line)
            if event["node"] in ("generate", "repair") and event.get("prompt"):
                calls.append(event)
    return calls


def row(repair: str, outcomes: list[dict], calls: list[dict], wall_s: float) -> dict:
    per_scenario_s = [o["timings_s"]["total"] for o in outcomes]
    per_call_out = [c["tokens_out"] for c in calls]
    per_call_s = [c["llm_latency_s"] for c in calls]
    statuses = {s: sum(o["status"] == s for o in outcomes)
                for s in ("ok", "repaired", "fallback", "failed")}
    return {
        "strategy": repair, "scenarios": len(outcomes), "statuses": statuses,
        "attempts_mean": round(statistics.mean(o["attempts"] for o in outcomes), 2),
        "tokens_out_per_scenario": round(statistics.mean(o["tokens_out"] for o in outcomes), 1),
        "tokens_out_per_call": round(statistics.mean(per_call_out), 1) if calls else 0,
        "tokens_in_per_call": round(statistics.mean(c["tokens_in"] for c in calls), 1)
        if calls else 0,
        "llm_s_per_call": round(statistics.mean(per_call_s), 2) if calls else 0,
        "tokens_per_s": round(sum(per_call_out) / sum(per_call_s), 1) if calls else 0,
        "wall_s_per_scenario_mean": round(statistics.mean(per_scenario_s), 2),
        "wall_s_per_scenario_p50": round(statistics.median(per_scenario_s), 2),
        "wall_s_total": round(wall_s, 1),
        "taxonomy": sorted(t for o in outcomes for t in o["error_taxonomy"]),
    }


def rates(outcomes: list[dict]) -> dict:
    """Success (ok or repaired), first-attempt success and fallback rate of ``outcomes``."""
    n = len(outcomes) or 1
    return {"n": len(outcomes),
            "success": round(sum(o["status"] in ("ok", "repaired") for o in outcomes) / n, 2),
            "first_attempt": round(sum(o["status"] == "ok" for o in outcomes) / n, 2),
            "fallback": round(sum(o["status"] == "fallback" for o in outcomes) / n, 2)}


def per_class(outcomes: list[dict]) -> dict[str, dict]:
    classes = sorted({o["maneuver_class"] for o in outcomes})
    return {c: rates([o for o in outcomes if o["maneuver_class"] == c]) for c in classes}


def print_rates(rows: list[dict]) -> None:
    print("strategy | class | n | success | first-attempt success | fallback")
    for r in rows:
        label = STRATEGY_LABELS.get(r["strategy"], r["strategy"])
        for name, found in [*r["per_class"].items(), ("all", r["rates"])]:
            print(f"{label} | {name} | {found['n']} | {found['success']:.0%} | "
                  f"{found['first_attempt']:.0%} | {found['fallback']:.0%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--classes", default="BRAKE,CINF,LCF,U4_1,U1_1")
    parser.add_argument("--repairs", default="error_feedback,patch")
    parser.add_argument("--max-attempts", type=int, default=3)
    parser.add_argument("--sandbox", default="bwrap")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    os.environ["SCENWEAVE_LLM_LOG"] = "0"

    from scenweave.ingest.samples import write_highway_samples, write_urban_samples

    classes = tuple(c for c in args.classes.split(",") if c)
    rows = []
    with tempfile.TemporaryDirectory(prefix="scenweave-bench-agent-") as tmp:
        raw = Path(tmp) / "raw"
        write_highway_samples(raw / "highway", seed=args.seed, per_class=1)
        write_urban_samples(raw / "urban", seed=args.seed, per_class=1)
        for repair in args.repairs.split(","):
            outcomes, wall = run_strategy(raw, Path(tmp) / "runs", classes, repair,
                                          args.max_attempts, args.sandbox)
            calls = llm_calls(outcomes, Path(tmp) / "runs" / repair)
            rows.append(row(repair, outcomes, calls, wall)
                        | {"rates": rates(outcomes), "per_class": per_class(outcomes)})
            if args.verbose:
                for o in outcomes:
                    print(json.dumps({k: o[k] for k in ("scenario_id", "status", "attempts",
                                                        "tokens_out", "timings_s")}))
    print(f"agent benchmark: embedded SmolLM2-135M, {len(classes)} records "
          f"({', '.join(classes)}), max {args.max_attempts} attempts, sandbox {args.sandbox}")
    header = ("strategy", "ok/rep/fb/fail", "attempts", "out tok/scen", "out tok/call",
              "in tok/call", "LLM s/call", "tok/s", "wall s/scen (mean, p50)")
    print(" | ".join(header))
    for r in rows:
        s = r["statuses"]
        print(" | ".join(str(x) for x in (
            STRATEGY_LABELS.get(r["strategy"], r["strategy"]),
            f"{s['ok']}/{s['repaired']}/{s['fallback']}/{s['failed']}", r["attempts_mean"],
            r["tokens_out_per_scenario"], r["tokens_out_per_call"], r["tokens_in_per_call"],
            r["llm_s_per_call"], r["tokens_per_s"],
            f"{r['wall_s_per_scenario_mean']}, {r['wall_s_per_scenario_p50']}")))
    print_rates(rows)
    print(json.dumps(rows))


if __name__ == "__main__":
    main()

"""What ``run --vary`` keeps when the model is right: every record of the sample data goes
through the agent with recorded replies a perfect model would give (the faithful script, then
the weather changed, and the vehicle model, the background vehicle and the lane changed to the
values ``ingest.variants.vary`` asks of the variant), with the real sandbox, validator and
esmini replay.

Prints per class and aspect how many variants were kept, and why the others were not (where
ScenWeave could not ask for an aspect of a record, no LLM call is made).

    .venv/bin/python benchmarks/variants.py [--per-class 3] [--seed 7] [--sandbox bwrap]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

VARY = 4  # weather, vehicles, traffic, lane: one round of scenweave.judge.variation.ASPECTS


def fenced(code: str) -> str:
    return f"```python\n{code}```\n"


def right_replies(raw: Path, map_name: str | None) -> dict[str, list[str]]:
    """scenario id -> what a perfect model answers: the faithful script, then each aspect
    (vehicles and lane: the values ``ingest.variants.vary`` asks, written in)."""
    from scenweave import corpus
    from scenweave.corpus.worked_example import worked_example
    from scenweave.ingest.variants import NotAsked, vary
    from scenweave.inputs import InputSelection, load_input
    from scenweave.runner import default_matcher, round_robin
    from scenweave.spawn_db import SpawnDbError

    matcher = default_matcher(map_name)
    replies = {}
    for index, params in round_robin(load_input(raw, InputSelection()).params):
        try:
            placed = matcher.assign(params, index)
        except SpawnDbError:
            continue
        script = corpus.retrieve(placed).script_path
        right = worked_example(script, placed)
        weather = "Night_Rain" if placed["weather_key"] != "Night_Rain" else "Day_Clear"
        answers = [right, right.replace(f'"{placed["weather_key"]}"', f'"{weather}"')]
        for aspect in ("vehicles", "traffic", "lane"):
            try:
                answers.append(worked_example(script, vary(placed, aspect, 0, matcher)))
            except NotAsked:
                continue  # no LLM call is made for it
        replies[params["scenario_id"]] = [fenced(answer) for answer in answers]
    return replies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=3)
    parser.add_argument("--classes", default="", help="e.g. BRAKE,CINF,LCF (default: all)")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--llm", default="replay", choices=("replay", "embedded"),
                        help="replay: a perfect model's replies; embedded: SmolLM2 itself")
    parser.add_argument("--repair", default="error_feedback",
                        help="the agent's strategy (patch: variants as JSON line edits)")
    parser.add_argument("--map", default=None, help="a bundled town or an .xodr (Town04)")
    parser.add_argument("--sandbox", default="bwrap")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    if args.llm == "replay" and args.repair == "patch":
        parser.error("the recorded replies are whole scripts: use --repair patch with "
                     "--llm embedded")
    os.environ["SCENWEAVE_LLM_LOG"] = "0"

    from scenweave.agent import AgentSettings
    from scenweave.agent.settings import batch_sandbox
    from scenweave.ingest.samples import write_highway_samples, write_urban_samples
    from scenweave.inputs import InputSelection
    from scenweave.pipeline import PipelineSettings
    from scenweave.player import ReplaySettings
    from scenweave.runner import run_batch

    classes = tuple(c for c in args.classes.split(",") if c)
    with tempfile.TemporaryDirectory(prefix="scenweave-bench-variants-") as tmp:
        raw = Path(tmp) / "raw"
        write_highway_samples(raw / "highway", seed=args.seed, per_class=args.per_class)
        write_urban_samples(raw / "urban", seed=args.seed, per_class=args.per_class)
        llm: dict = {"llm": args.llm}
        if args.llm == "replay":
            replies = Path(tmp) / "replies.json"
            replies.write_text(json.dumps(right_replies(raw, args.map)), encoding="utf-8")
            llm["replay_file"] = replies
        settings = PipelineSettings(no_llm=False, replay=ReplaySettings(), vary=VARY, map=args.map,
                                    agent=AgentSettings(**llm, repair=args.repair,
                                                        sandbox=batch_sandbox(args.sandbox)))
        started = time.perf_counter()
        result = run_batch(raw, Path(tmp) / "runs", InputSelection(classes=classes), settings,
                           run_id="vary", jobs=args.jobs)
        wall = time.perf_counter() - started
    outcomes = result.summary["scenarios"]
    kept: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
    why: Counter = Counter()
    for o in outcomes:
        for v in o.get("variants", []):
            counts = kept[(o["maneuver_class"], v["aspect"])]
            counts[0] += bool(v["kept"])
            counts[1] += 1
            if not v["kept"]:
                why[(v["aspect"], (v["errors"] or ["?"])[0].split(":")[0])] += 1
                if args.verbose:
                    print(o["scenario_id"], v["aspect"], v["errors"][:2])
    aspects = ("weather", "vehicles", "traffic", "lane")
    model = "recorded right replies" if args.llm == "replay" else "embedded SmolLM2-135M"
    print(f"variants benchmark: {args.map or 'Town04'}, sample data seed {args.seed}, "
          f"{len(outcomes)} records, "
          f"--vary {VARY}, {model}, --repair {args.repair}, replay on, {wall:.0f} s")
    print(f"delivered: {Counter(o['status'] for o in outcomes)}")
    print("class | " + " | ".join(aspects))
    for code in sorted({c for c, _ in kept}):
        cells = [f"{kept[(code, a)][0]}/{kept[(code, a)][1]}" if (code, a) in kept else "-"
                 for a in aspects]
        print(f"{code} | " + " | ".join(cells))
    totals = [sum(kept[(c, a)][0] for c, b in kept if b == a) for a in aspects]
    asked = [sum(kept[(c, a)][1] for c, b in kept if b == a) for a in aspects]
    print("all | " + " | ".join(f"{k}/{n}" for k, n in zip(totals, asked, strict=True)))
    print("not kept, by aspect and first reason:")
    for (aspect, code), count in sorted(why.items()):
        print(f"  {aspect}: {code} x{count}")


if __name__ == "__main__":
    main()

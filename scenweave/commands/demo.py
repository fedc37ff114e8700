"""``scenweave demo``: the main job end to end on built-in sample data.

Sample data in the MOOVE formats -> canonical records -> every record through the reference
scripts (``--no-llm``), then a few records through the agent with the embedded model, so a
fresh machine shows the whole pipeline in a few minutes.
"""

from __future__ import annotations

import fcntl
import importlib
import importlib.util
import time
from pathlib import Path

import click

from scenweave.commands.agent_options import (
    LlmChoice,
    auto_llm,
    echo_not_played,
    pipeline_settings,
    replay_plan_for,
)
from scenweave.ingest import ingest_directory
from scenweave.ingest.samples import write_highway_samples, write_urban_samples
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.runner import run_batch

#: car-following rows per FL class that only a speed profile of two phases shows (issue 22):
#: they follow the seeded rows, which stay the same
PHASED_ROWS = 1
#: held while ``scripts/setup.sh --llm-later`` installs llama-cpp-python in the background
#: (a clone's build folder; a pip install has none)
LLAMA_INSTALL_LOCK = Path(__file__).resolve().parents[2] / "build" / "llama-install.lock"


@click.command("demo")
@click.option("--out", "out_dir", default="runs/demo", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Where the demo writes.")
@click.option("--seed", default=7, show_default=True, help="Seed of the sample data.")
@click.option("--per-class", default=3, show_default=True, type=click.IntRange(1),
              help="Sample records per class.")
@click.option("--llm", type=LlmChoice(), default="embedded", show_default=True,
              help="LLM of the agent part (the demo shows the agent with the built-in model); "
                   "none skips it, auto uses Ollama when it answers.")
@click.option("--agent-classes", default="BRAKE,U4_1", show_default=True,
              help="Classes whose first record goes through the agent.")
@click.option("--repair", default="error-feedback", show_default=True,
              help="Repair strategy of the agent part.")
def demo(out_dir: Path, seed: int, per_class: int, llm: str, agent_classes: str,
         repair: str) -> None:
    """Make sample data, ingest it, turn every record into a validated scenario, then run
    the agent with a local LLM on a few of them."""
    raw = out_dir / "sample_data"
    write_highway_samples(raw / "highway", seed, per_class, phased=PHASED_ROWS)
    write_urban_samples(raw / "urban", seed, per_class)
    records = out_dir / "records"
    report = ingest_directory(raw, records)
    click.echo(f"demo: sample data in {raw}; {report.records_written} canonical records in "
               f"{records} ({len(report.errors)} input errors)")
    plan = replay_plan_for(None)
    result = run_batch(records, out_dir / "runs", InputSelection(),
                       PipelineSettings(no_llm=True, replay=plan.settings,
                                        replay_not_run=plan.not_run_because),
                       run_id="no-llm")
    click.echo(result.line())
    echo_not_played(result.summary, result.folder.root)
    if llm == "auto":
        llm = auto_llm(None)
    if llm == "none":
        return
    if llm == "embedded":
        wait_for_embedded_runtime()
    classes = tuple(c.strip() for c in agent_classes.split(",") if c.strip())
    agent = run_batch(records, out_dir / "runs", InputSelection(classes=classes, per_class=1),
                      pipeline_settings(False, 5, llm=llm, repair=repair),
                      run_id=f"agent-{llm}")
    click.echo(agent.line())
    echo_not_played(agent.summary, agent.folder.root)
    click.echo(attempts_line(agent.summary))
    click.echo(f"demo: inspect a scenario with: scenweave trace "
               f"{agent.summary['scenarios'][0]['scenario_id']} --runs {out_dir / 'runs'}"
               if agent.summary["scenarios"] else "demo: the agent had no records to run")


def wait_for_embedded_runtime(lock: Path = LLAMA_INSTALL_LOCK) -> None:
    """When setup left llama-cpp-python compiling (``setup.sh --llm-later``), wait until it is
    installed: the reference part ran meanwhile, the agent part needs it."""
    if importlib.util.find_spec("llama_cpp") is not None or not lock.is_file():
        return
    click.echo("demo: waiting for llama-cpp-python, compiling since setup (log "
               f"{lock.parent / 'llama-prebuild.log'})")
    started = time.monotonic()
    with open(lock) as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
    importlib.invalidate_caches()
    click.echo(f"demo: llama-cpp-python ready after {time.monotonic() - started:.0f} s")


def attempts_line(summary: dict) -> str:
    """What the LLM's attempts came to: how many, how many failed and of which kind (the
    scenarios' counts alone hide that a fallback followed three failed attempts)."""
    kinds = summary["error_taxonomy"]
    failed = sum(kinds.values())
    detail = " (" + ", ".join(f"{n} {kind}" for kind, n in sorted(
        kinds.items(), key=lambda item: -item[1])) + ")" if failed else ""
    return (f"agent: {summary['attempts']} LLM attempts, {failed} failed{detail}; "
            f"{summary['first_attempt_success']} right the first time")

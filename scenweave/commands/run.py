"""``scenweave run DATA``: records in, validated scenarios out, in ``runs/<run_id>/``."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave.commands.agent_options import agent_options, map_option, pipeline_settings
from scenweave.inputs import InputSelection
from scenweave.runner import run_batch


@click.command("run")
@click.argument("data", type=click.Path(exists=True, path_type=Path))
@click.option("--out", "out_root", default="runs", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Folder for run folders.")
@click.option("--no-llm", is_flag=True, help="Run the reference scripts directly (thesis §5).")
@click.option("--run-id", help="Name of the run folder; an existing one is resumed.")
@click.option("--classes", help="Comma-separated class codes to run, e.g. BRAKE,CINF,U4_1.")
@click.option("--per-class", type=click.IntRange(1), help="At most N records per class.")
@click.option("--limit", type=click.IntRange(1), help="At most N scenarios in all.")
@click.option("--variants", default=0, show_default=True, type=click.IntRange(0),
              help="Perturbed copies per record (extract_with_variants).")
@click.option("--seed", default=0, show_default=True, help="Seed for the variants.")
@click.option("--vary", default=0, show_default=True, type=click.IntRange(0),
              help="Variants the LLM writes of each delivered scenario, one aspect in turn: "
                   "weather, a vehicle model (bumper gaps kept), a background vehicle in a "
                   "free lane, the record one lane over; each must still replay the record.")
@click.option("--layout", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Highway column-layout JSON for raw .npy input.")
@click.option("--top-n", default=5, show_default=True, type=click.IntRange(1),
              help="Spawn candidates shared round robin per class.")
@click.option("--retry-failed", is_flag=True, help="On resume, run failed scenarios again.")
@click.option("--jobs", default=1, show_default=True, type=click.IntRange(1),
              help="Make scenarios in N processes (e.g. one per core).")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json instead of a line.")
@map_option()
@agent_options
def run(data: Path, out_root: Path, no_llm: bool, run_id: str | None, classes: str | None,
        per_class: int | None, limit: int | None, variants: int, seed: int, vary: int,
        layout: Path | None, top_n: int, retry_failed: bool, jobs: int, as_json: bool,
        **agent: object) -> None:
    """Turn DATA (raw MOOVE files or canonical records) into validated .xosc scenarios.

    By default the agent has the embedded model adapt each reference script; --llm ollama
    uses an Ollama server, --no-llm runs the reference scripts directly.
    """
    settings = pipeline_settings(no_llm, top_n, **agent)
    if vary and settings.no_llm:
        raise click.UsageError("--vary needs an LLM: the LLM writes the variants (drop --no-llm)")
    settings.vary = vary
    selection = InputSelection(
        classes=tuple(c.strip() for c in classes.split(",")) if classes else (),
        per_class=per_class, limit=limit, variants=variants, seed=seed, layout=layout)
    result = run_batch(data, out_root, selection, settings, run_id=run_id,
                       retry_failed=retry_failed, jobs=jobs)
    if as_json:
        click.echo(json.dumps(result.summary, indent=1))
    else:
        for issue in result.input_issues[:10]:
            click.echo(f"input: {issue['file']}: {issue['message']}", err=True)
        for line in spawn_failures(result.summary):
            click.echo(line, err=True)
        click.echo(result.line())


def spawn_failures(summary: dict) -> list[str]:
    """One line per scenario no spawn point fits (e.g. a highway record on a map without a
    highway), naming the record and why."""
    return [f"spawn: {outcome['error'].removeprefix('NoSpawnFits: ')}"
            for outcome in summary["scenarios"]
            if "spawn" in outcome.get("error_taxonomy", []) and outcome.get("error")]

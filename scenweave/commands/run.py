"""``scenweave run DATA``: records in, validated scenarios out, in ``runs/<run_id>/``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import (
    agent_options,
    class_codes,
    echo_not_played,
    json_option,
    map_option,
    pipeline_settings,
)
from scenweave.commands.where_option import where_option
from scenweave.console import problem_lines
from scenweave.errors import InputError
from scenweave.inputs import InputSelection
from scenweave.mining.where import NothingMatched
from scenweave.runner import latest_run_of, run_batch
from scenweave.schemas.scenario_folder import SUMMARY_FILE
from scenweave.spawn_db.registry import DEFAULT_MATCHER, matcher_factory, matcher_for


def known_matcher(ctx: click.Context, param: click.Parameter, value: str) -> str:
    """``--matcher`` of a command that makes the matcher here: a registered name or a
    ``module:callable`` that imports now, else a usage error naming the choices."""
    try:
        matcher_factory(value)
    except InputError as err:
        raise click.BadParameter(str(err), ctx=ctx, param=param) from err
    return value


def resumed_run_id(data: Path, out_root: Path, selection: InputSelection,
                   run_id: str | None) -> str:
    """``--resume``: the id of the run last started on ``data`` with ``selection``; a usage
    error (nothing written) when ``--run-id`` names one too or there is none."""
    if run_id:
        raise click.UsageError("--resume finds the run to resume; --run-id names it: pass one")
    found = latest_run_of(data, out_root, selection)
    if found is None:
        raise click.UsageError(f"--resume: no run of {data} with this selection in {out_root} "
                               "to resume (drop --resume to start one)")
    return found


@click.command("run")
@click.argument("data", type=click.Path(exists=True, path_type=Path))
@click.option("--out", "out_root", default="runs", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Folder for run folders.")
@click.option("--no-llm", is_flag=True, help="Run the reference scripts directly (thesis §5).")
@click.option("--run-id", help="Name of the run folder; an existing one is resumed.")
@click.option("--resume", is_flag=True,
              help="Resume the run last started on DATA with the same selection in --out (a "
                   "run prints its id as it starts); a usage error when there is none.")
@click.option("--classes", callback=class_codes,
              help="Comma-separated class codes to run, e.g. BRAKE,CINF,U4_1.")
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
@click.option("--matcher", default=DEFAULT_MATCHER, show_default=True, callback=known_matcher,
              help="Spawn matcher: a registered name (default, or a plugin's: "
                   "docs/plugins.md) or module:callable, called with the map.")
@where_option()
@json_option(SUMMARY_FILE)
@map_option()
@agent_options
def run(data: Path, out_root: Path, no_llm: bool, run_id: str | None, resume: bool,
        classes: tuple[str, ...], per_class: int | None, limit: int | None, variants: int,
        seed: int, vary: int,
        layout: Path | None, top_n: int, retry_failed: bool, jobs: int, matcher: str,
        where: Any, as_json: bool, **agent: Any) -> None:
    """Turn DATA (raw MOOVE files or canonical records) into validated .xosc scenarios.

    By default (--llm auto) the agent has the Ollama server adapt each reference script when
    one answers, else the reference scripts run directly (as with --no-llm); --llm embedded
    uses the built-in SmolLM2. Exit status: 0 all delivered, 1 a record refused or a scenario
    failed (or none made), 2 usage error, 130 interrupted.
    """
    settings = pipeline_settings(no_llm, top_n, **agent)
    if vary and settings.no_llm:
        raise click.UsageError("--vary needs an LLM: the LLM writes the variants (drop --no-llm)")
    settings.vary = vary
    selection = InputSelection(classes=classes, per_class=per_class, limit=limit,
                               variants=variants, seed=seed, layout=layout,
                               where=where.text if where is not None else None)
    if resume:
        run_id = resumed_run_id(data, out_root, selection, run_id)
    try:
        result = run_batch(data, out_root, selection, settings, run_id=run_id,
                           retry_failed=retry_failed, matcher=matcher_for(matcher, settings.map),
                           jobs=jobs, announce=True)
    except NothingMatched as err:  # found before any run folder is made: nothing written
        click.echo(str(err), err=True)
        raise click.exceptions.Exit(exit_codes.PROBLEMS) from err
    if as_json:
        click.echo(json.dumps(result.summary, indent=1))
    else:
        click.echo(result.line())
        echo_not_played(result.summary, result.folder.root)
        for line in problem_lines(result.input_issues, result.summary["scenarios"],
                                  str(result.folder.root / SUMMARY_FILE)):
            click.echo(line, err=True)
    exit_codes.finish(result.problems)

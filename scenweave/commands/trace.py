"""``scenweave trace SCENARIO_ID``: what the agent did for one scenario, node by node."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave.commands.agent_options import json_option
from scenweave.traces import TraceNotFound, find_scenario, format_trace, read_events


@click.command("trace")
@click.argument("scenario_id")
@click.option("--runs", "runs_root", default="runs", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Folder of run folders.")
@click.option("--run", "run_id", help="Run id; default: the newest run with this scenario.")
@click.option("--full", is_flag=True, help="Show prompts, replies, code and diffs whole.")
@json_option("the events")
def trace(scenario_id: str, runs_root: Path, run_id: str | None, full: bool,
          as_json: bool) -> None:
    """Show each node in order: prompt, raw reply, extracted code, diff to the reference,
    sandbox result, validation errors, timings and tokens."""
    try:
        folder = find_scenario(scenario_id, runs_root, run_id)
    except TraceNotFound as err:
        raise click.ClickException(str(err)) from err
    if as_json:
        click.echo(json.dumps(read_events(folder), indent=1))
    else:
        click.echo(format_trace(folder, scenario_id, full))

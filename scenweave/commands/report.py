"""``scenweave report RUN_DIR``: (re)write a run's summary.json and report.html."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave.commands.agent_options import json_option
from scenweave.presentation.report import write_run_report
from scenweave.schemas.scenario_folder import STATUS_NAME, SUMMARY_FILE


@click.command("report")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@json_option("the refreshed summary.json")
def report(run_dir: Path, as_json: bool) -> None:
    """Write RUN_DIR/report.html from the scenario folders (summary.json is refreshed)."""
    from scenweave.queue.collector import refresh_run

    if not (run_dir / SUMMARY_FILE).exists() and not any(run_dir.glob(f"*/{STATUS_NAME}")):
        raise click.UsageError(f"{run_dir}: not a run folder (no summary.json, no scenarios)")
    summary = refresh_run(run_dir)
    path = write_run_report(run_dir)
    if as_json:
        click.echo(json.dumps(summary, indent=1))
        return
    counts = ", ".join(f"{v} {k}" for k, v in summary["counts"].items())
    click.echo(f"report of run {summary['run_id']}: {summary['total']} scenarios: {counts} "
               f"-> {path}")

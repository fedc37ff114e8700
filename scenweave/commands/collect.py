"""``scenweave collect RUN_DIR``: the scenario folders workers handed back, into the run folder.

Safe to run again at any time (and beside ``submit --wait``): each scenario is written once.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import echo_not_played, json_option
from scenweave.console import problem_lines
from scenweave.queue.connection import QUEUE_ENV
from scenweave.schemas.scenario_folder import RUN_FILE, SUMMARY_FILE

QUEUE_HELP = ("Redis URL of the job queue (rediss:// for TLS, a password as "
              "redis://:PASSWORD@host:6379/0) [default: redis://127.0.0.1:6379/0].")


def collect_run(run_dir: Path, connection: Any, wait: bool, timeout: float | None) -> Any:
    """Collect (a bar of committed scenarios on a terminal while waiting), say what happened."""
    from tqdm import tqdm

    from scenweave.queue.collector import collect

    with tqdm(desc="collected", unit="scenario", leave=False,
              disable=not (wait and sys.stderr.isatty())) as bar:

        def count(committed: int) -> None:
            bar.update(committed)

        result = collect(run_dir, connection, wait=wait, timeout_s=timeout, on_commit=count)
    for note in result.notes:
        click.echo(f"collect: {note}", err=True)
    for scenario_id in result.lost:
        click.echo(f"collect: {scenario_id}: its job is no longer in the queue and handed "
                   "nothing back; submit the same --run-id again", err=True)
    return result


@click.command("collect")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--queue", "url", envvar=QUEUE_ENV, show_envvar=True, help=QUEUE_HELP)
@click.option("--wait", is_flag=True,
              help="Keep collecting until no scenario of the run is queued or running.")
@click.option("--timeout", type=click.FloatRange(0), default=None,
              help="With --wait: stop waiting after this many seconds.")
@json_option("the run's summary.json")
def collect(run_dir: Path, url: str | None, wait: bool, timeout: float | None,
            as_json: bool) -> None:
    """Write the scenario folders the workers handed back into RUN_DIR (atomically, once
    each), then its summary.json and, when every scenario is in, its report.html."""
    from scenweave.queue.connection import connect

    if not (run_dir / RUN_FILE).is_file():
        raise click.UsageError(f"{run_dir} is not a run folder (no {RUN_FILE}); give the "
                               "folder scenweave submit printed, e.g. runs/<run_id>")
    result = collect_run(run_dir, connect(url), wait, timeout)
    if as_json:
        click.echo(json.dumps(result.summary, indent=1))
    else:
        click.echo(result.line())
        echo_not_played(result.summary, run_dir)
        for line in problem_lines(result.summary.get("input_issues", []),
                                  result.summary.get("scenarios", []),
                                  str(run_dir / SUMMARY_FILE)):
            click.echo(line, err=True)
    failed = any(o.get("status") == "failed" for o in result.summary.get("scenarios", []))
    exit_codes.finish(bool(result.lost) or failed or (wait and not result.complete))

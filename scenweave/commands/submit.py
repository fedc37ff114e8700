"""``scenweave submit DATA --queue URL``: enqueue a run's scenarios for the GPU-host workers.

Takes the same input and selection options as ``scenweave run`` (the very same click options),
plus where the queue is and how jobs are retried.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import (
    AGENT_OPTION_NAMES,
    echo_not_played,
    pipeline_settings,
)
from scenweave.commands.collect import QUEUE_HELP, collect_run
from scenweave.commands.run import run as run_command
from scenweave.console import problem_lines, refused_records
from scenweave.errors import InputError
from scenweave.inputs import InputSelection
from scenweave.queue.connection import QUEUE_ENV, connect
from scenweave.queue.handoff import MIB, Limits
from scenweave.queue.job import JobOptions
from scenweave.queue.submit import submit
from scenweave.schemas.scenario_folder import SUMMARY_FILE
from scenweave.spawn_db.registry import DEFAULT_MATCHER, matcher_factory

#: options of ``scenweave run`` that mean the same here
SHARED_OPTIONS = ("data", "out_root", "no_llm", "run_id", "classes", "per_class", "limit",
                  "variants", "seed", "layout", "top_n", "retry_failed", "map_ref",
                  *AGENT_OPTION_NAMES)


def _delays(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError as err:
        raise click.BadParameter(f"{text!r}: give seconds like 10,60,300") from err


def _checked_matcher(ctx: click.Context, param: click.Parameter, value: str) -> str:
    """A registered matcher's name must be known here already; ``module:callable`` is
    imported by the workers (which may have more installed than this machine)."""
    if ":" not in value:
        try:
            matcher_factory(value)
        except InputError as err:
            raise click.BadParameter(str(err), ctx=ctx, param=param) from err
    return value


def _submit(url: str | None, retries: int, retry_delays: str, job_timeout: int, matcher: str,
            max_artefact_mb: float, wait: bool, timeout: float | None, as_json: bool,
            no_llm: bool, top_n: int, **selection_and_run: Any) -> None:
    """Enqueue one job per scenario of DATA; workers (``scenweave worker``, on any machine
    that reaches the queue) make them and hand each folder back through the queue; --wait (or
    ``scenweave collect RUN_DIR`` later) writes them into the run folder."""
    agent = {name: selection_and_run.pop(name) for name in AGENT_OPTION_NAMES}
    settings = pipeline_settings(no_llm, top_n, map_ref=selection_and_run.pop("map_ref"), **agent)
    data, out_root = selection_and_run.pop("data"), selection_and_run.pop("out_root")
    run_id, retry_failed = selection_and_run.pop("run_id"), selection_and_run.pop("retry_failed")
    selection = InputSelection(**selection_and_run)  # --classes: codes checked by run's option
    options = JobOptions(retries=retries, retry_delays_s=_delays(retry_delays),
                         timeout_s=job_timeout, matcher=matcher,
                         limits=Limits(file_bytes=int(max_artefact_mb * MIB),
                                       total_bytes=int(4 * max_artefact_mb * MIB)))
    connection = connect(url)
    result = submit(Path(data), Path(out_root), selection, settings, connection, run_id=run_id,
                    retry_failed=retry_failed, options=options)
    if as_json:
        click.echo(json.dumps({"run_id": result.folder.run_id, "folder": str(result.folder.root),
                               "enqueued": result.enqueued, "already_done": result.already_done,
                               "already_queued": result.already_queued,
                               "input_issues": result.input_issues}, indent=1))
    else:
        click.echo(result.line())
    collected = collect_run(result.folder.root, connection, wait, timeout)
    outcomes = collected.summary.get("scenarios", []) if wait else []
    if wait and not as_json:
        click.echo(collected.line())
        echo_not_played(collected.summary, result.folder.root)
    if not as_json:
        for line in problem_lines(result.input_issues, outcomes,
                                  str(result.folder.root / SUMMARY_FILE)):
            click.echo(line, err=True)
    failed = any(o.get("status") == "failed" for o in outcomes)
    unfinished = wait and (bool(collected.lost) or not collected.complete
                           or not collected.summary.get("total"))
    exit_codes.finish(refused_records(result.input_issues) > 0 or failed or unfinished)


submit_command = click.Command(
    "submit", callback=_submit, help=_submit.__doc__,
    params=[*(p for p in run_command.params if p.name in SHARED_OPTIONS),
            click.Option(["--queue", "url"], envvar=QUEUE_ENV, show_envvar=True, help=QUEUE_HELP),
            click.Option(["--retries"], default=3, show_default=True, type=click.IntRange(0),
                         help="Retries of a scenario after an infrastructure error."),
            click.Option(["--retry-delays"], default="10,60,300", show_default=True,
                         help="Seconds before each retry, comma-separated."),
            click.Option(["--job-timeout"], default=3600, show_default=True,
                         type=click.IntRange(1), help="Seconds one scenario may take."),
            click.Option(["--matcher"], default=DEFAULT_MATCHER, show_default=True,
                         callback=_checked_matcher,
                         help="Spawn matcher the workers use: a registered name (default, or "
                              "a plugin's: docs/plugins.md) or module:callable."),
            click.Option(["--max-artefact-mb"], default=16.0, show_default=True,
                         type=click.FloatRange(0.001),
                         help="Largest file a worker hands back (a scenario's folder: 4x); "
                              "larger ones stay behind and status.json says so."),
            click.Option(["--wait"], is_flag=True,
                         help="Wait for the workers and write every scenario folder, "
                              "summary.json and report.html into the run folder."),
            click.Option(["--timeout"], type=click.FloatRange(0), default=None,
                         help="With --wait: stop waiting after this many seconds "
                              "(scenweave collect RUN_DIR goes on later)."),
            click.Option(["--json", "as_json"], is_flag=True,
                         help="Print what was enqueued as JSON.")])

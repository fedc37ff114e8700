"""``scenweave worker``: do the queued scenarios of any run, on the GPU host."""

from __future__ import annotations

from pathlib import Path

import click

from scenweave.commands.agent_options import map_option
from scenweave.commands.collect import QUEUE_HELP
from scenweave.queue.connection import QUEUE_ENV
from scenweave.queue.job import SCRATCH_ENV
from scenweave.queue.worker import WorkerOptions, work, work_in_processes
from scenweave.spawn_db.registry import DEFAULT_MATCHER


@click.command("worker")
@click.option("--queue", "url", envvar=QUEUE_ENV, show_envvar=True, help=QUEUE_HELP)
@click.option("--scratch", type=click.Path(file_okay=False, path_type=Path), envvar=SCRATCH_ENV,
              show_envvar=True, help="Folder this worker makes scenarios in (each job's "
                                     "folder goes once handed back) [default: a temp folder].")
@click.option("--workers", "count", default=1, show_default=True, type=click.IntRange(1),
              help="Worker processes: as many as the LLM server serves in parallel.")
@click.option("--burst", is_flag=True, help="Stop when the queue is empty.")
@click.option("--heartbeat", default=30, show_default=True, type=click.IntRange(1),
              help="Seconds between heartbeats; a job is abandoned after 2 missed + 10 s.")
@click.option("--maintenance-interval", default=60, show_default=True, type=click.IntRange(1),
              help="Seconds between looks for jobs of dead workers.")
@click.option("--preload", default=DEFAULT_MATCHER, show_default=True,
              help="Spawn matcher (a registered name or module:callable) to load once "
                   "before work starts.")
@map_option(help="Map whose spawn matcher is loaded (and database built) before work starts: "
                 "a bundled CARLA town or an .xodr path. Jobs name their own map.  "
                 "[default: Town04]")
def worker(url: str | None, scratch: Path | None, count: int, burst: bool, heartbeat: int,
           maintenance_interval: int, preload: str, map_ref: object) -> None:
    """Run queued scenarios (from ``scenweave submit``) until stopped; Ctrl-C or SIGTERM
    stops after the current scenario. Needs only the queue: each scenario is made in the
    scratch folder and handed back through Redis."""
    options = WorkerOptions(burst=burst, heartbeat_s=heartbeat,
                            maintenance_interval_s=maintenance_interval,
                            preload_matcher=preload or None,
                            preload_map=getattr(map_ref, "logic_file", None), scratch=scratch)
    if count == 1:
        worked = work(url, options)
        click.echo(f"worker stopped ({'did some scenarios' if worked else 'no scenarios done'})")
    else:
        clean = work_in_processes(url, options, count)
        click.echo(f"workers stopped: {clean} of {count} exited cleanly")

"""The exit codes every command shares (README, "Exit codes"), so a CI job around ScenWeave can
tell what happened, as it can around esmini or scenario_runner."""

from __future__ import annotations

import click

#: everything asked for was delivered ok
DELIVERED = 0
#: the batch finished, but a record was refused, a scenario failed, or nothing was produced
PROBLEMS = 1
#: a usage error (unknown class, unknown map, missing path, bad option), found before anything
#: was written (click's own code for usage errors)
USAGE = 2
#: interrupted (Ctrl-C); the line printed says how to resume
INTERRUPTED = 130


def finish(problems: bool) -> None:
    """End the command with ``PROBLEMS`` when there were any, else return (exit 0)."""
    if problems:
        raise click.exceptions.Exit(PROBLEMS)

"""``scenweave doctor``: which optional parts work on this machine, one line each."""

from __future__ import annotations

import json

import click

from scenweave.commands.agent_options import json_option


@click.command("doctor")
@json_option("the findings")
def doctor(as_json: bool) -> None:
    """Report the player (esmini), sandbox backends, embedded LLM, Ollama and Redis.

    Exits 0 even when parts are missing: it is a report; each missing part says why.
    """
    from scenweave.doctor import describe, diagnose

    report = diagnose()
    if as_json:
        click.echo(json.dumps(report, indent=1))
        return
    for name, found in report.items():
        click.echo(describe(name, found))
    missing = [name for name, found in report.items() if not found["available"]]
    click.echo(f"doctor: {len(report) - len(missing)} of {len(report)} parts available"
               + (f"; missing: {', '.join(missing)}" if missing else ""))

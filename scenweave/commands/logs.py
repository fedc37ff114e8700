"""``scenweave logs``: the newest LLM calls from ``$SCENWEAVE_HOME/llm-calls.sqlite``."""

from __future__ import annotations

import json

import click


@click.command("logs")
@click.option("-n", "--count", default=10, show_default=True, type=click.IntRange(1),
              help="How many calls, newest first.")
@click.option("--scenario", help="Only the calls of this scenario id.")
@click.option("--full", is_flag=True, help="Show prompts and replies whole.")
@click.option("--json", "as_json", is_flag=True, help="Print the calls as a JSON list.")
def logs(count: int, scenario: str | None, full: bool, as_json: bool) -> None:
    """List logged LLM calls: when, backend, model, scenario, tokens, latency, reply."""
    from scenweave.agent.llm.log import log_path, recent_calls

    calls = recent_calls(count, scenario)
    if as_json:
        click.echo(json.dumps(calls, indent=1))
        return
    if not calls:
        click.echo(f"no LLM calls logged in {log_path()}")
    for call in calls:
        click.echo(f"#{call['id']} {call['at']} {call['backend']}/{call['model']} "
                   f"{call['scenario_id'] or '-'} ({call['purpose']}): {call['tokens_in']} in, "
                   f"{call['tokens_out']} out, {call['latency_s']:.2f} s")
        reply = call["reply"] or ""
        lines = [line for line in reply.splitlines() if line.strip()
                 and not line.startswith("```")]
        click.echo(reply if full else "  " + (lines[0][:100] if lines else "(empty reply)"))

"""``scenweave logs``: the newest LLM calls from ``$SCENWEAVE_HOME/llm-calls.sqlite``."""

from __future__ import annotations

import json
import re

import click

from scenweave.commands.agent_options import json_option

#: characters of a reply shown per call without ``--full``
PREVIEW_CHARS = 110


@click.command("logs")
@click.option("-n", "--count", default=10, show_default=True, type=click.IntRange(1),
              help="How many calls, newest first.")
@click.option("--run", "run_id", help="Only the calls of this run id.")
@click.option("--scenario", help="Only the calls of this scenario id.")
@click.option("--model", help="Only the calls to this model.")
@click.option("--full", is_flag=True, help="Show prompts and replies whole.")
@json_option("the calls")
def logs(count: int, run_id: str | None, scenario: str | None, model: str | None, full: bool,
         as_json: bool) -> None:
    """List logged LLM calls: when, run, backend, model, scenario, tokens, latency, reply."""
    from scenweave.agent.llm.log import log_path, recent_calls

    calls = recent_calls(count, scenario, run_id, model)
    if as_json:
        click.echo(json.dumps(calls, indent=1))
        return
    if not calls:
        click.echo(f"no LLM calls logged in {log_path()}")
    for call in calls:
        click.echo(f"#{call['id']} {call['at']} run {call.get('run_id') or '-'} "
                   f"{call['backend']}/{call['model']} {call['scenario_id'] or '-'} "
                   f"({call['purpose']}): {call['tokens_in']} in, {call['tokens_out']} out, "
                   f"{call['latency_s']:.2f} s")
        click.echo(call["reply"] if full else "  " + reply_preview(call["reply"] or ""))


def reply_preview(reply: str, width: int = PREVIEW_CHARS) -> str:
    """What the reply says, on one line: without code fences and the import lines every
    script starts with (they made every preview read "import json")."""
    lines = [line.strip() for line in reply.splitlines()
             if line.strip() and not line.strip().startswith("```")
             and not re.match(r"(import|from)\s+\w", line.strip())]
    text = re.sub(r"\s+", " ", " ".join(lines))
    if not text:
        return "(empty reply)"
    return text if len(text) <= width else text[:width - 1] + "…"

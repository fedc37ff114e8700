"""``scenweave doctor``: which optional parts work on this machine, one line each."""

from __future__ import annotations

import json

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import json_option


def _needs(ctx: click.Context, param: click.Parameter, value: str | None) -> tuple[str, ...]:
    """``--need player,bwrap``: names the doctor knows (a typo is a usage error)."""
    from scenweave.doctor import need_names

    needs = tuple(n.strip().lower() for n in (value or "").split(",") if n.strip())
    unknown = [n for n in needs if n not in need_names()]
    if unknown:
        raise click.BadParameter(f"unknown part {', '.join(unknown)} (known: "
                                 f"{', '.join(need_names())})", ctx=ctx, param=param)
    return needs


@click.command("doctor")
@json_option("the findings")
@click.option("--need", "needs", callback=_needs, metavar="PART,...",
              help="Parts this machine must have: player (esmini), sandbox, docker, bwrap, "
                   "embedded_llm, ollama, redis (queue). Exit status 1 when one is missing.")
def doctor(as_json: bool, needs: tuple[str, ...]) -> None:
    """Report the player (esmini), sandbox backends, embedded LLM, Ollama and Redis, each
    missing one with the command or setting that provides it.

    Exits 0 when nothing asked for with --need is missing (without --need it is a report);
    1 when a part named in --need is missing.
    """
    from scenweave.doctor import describe, diagnose, missing_needs

    report = diagnose()
    lacking = missing_needs(report, needs)
    if as_json:
        click.echo(json.dumps({**report, **({"needs": {"asked": list(needs),
                                                       "missing": lacking}} if needs else {})},
                              indent=1))
    else:
        for name, found in report.items():
            click.echo(describe(name, found))
        missing = [name for name, found in report.items() if not found["available"]]
        click.echo(f"doctor: {len(report) - len(missing)} of {len(report)} parts available"
                   + (f"; missing: {', '.join(missing)}" if missing else ""))
        if lacking:
            click.echo(f"doctor: needed but missing: {', '.join(lacking)}", err=True)
    exit_codes.finish(bool(lacking))

"""``scenweave sandbox check``: which sandbox backends work on this host, and why not."""

from __future__ import annotations

import json

import click

from scenweave.commands.agent_options import json_option
from scenweave.sandbox import SandboxSettings, check_backends


@click.group("sandbox")
def sandbox() -> None:
    """The sandbox that runs LLM-written scripts."""


@sandbox.command("check")
@click.option("--docker-host", help="Container engine URL (default: $DOCKER_HOST, else podman's "
                                    "socket).")
@click.option("--image", default=SandboxSettings.image, show_default=True,
              help="Sandbox image for the docker backend.")
@click.option("--python", "python", default=SandboxSettings.python, show_default=True,
              help="Interpreter the bwrap backend runs.")
@json_option("the findings")
def check(docker_host: str | None, image: str, python: str, as_json: bool) -> None:
    """Probe every backend with a trivial sandboxed run; exit 1 when none works."""
    settings = SandboxSettings(docker_host=docker_host, image=image, python=python)
    reasons = check_backends(settings)
    # backends come in the order `--sandbox auto` prefers them
    auto_name = next((name for name, reason in reasons.items() if reason is None), None)
    if as_json:
        click.echo(json.dumps({"backends": {name: {"works": reason is None, "reason": reason}
                                            for name, reason in reasons.items()},
                               "auto": auto_name}, indent=1))
    else:
        for name, reason in reasons.items():
            click.echo(f"{name}: " + ("works" if reason is None else f"unavailable: {reason}"))
        working = [name for name, reason in reasons.items() if reason is None]
        click.echo(f"sandbox: {len(working)} of {len(reasons)} backends work; "
                   f"--sandbox auto picks {auto_name or 'nothing'}")
    if auto_name is None:
        raise SystemExit(1)

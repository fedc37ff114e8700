"""Options shared by the commands: the agent's (``run``, ``submit``, ``demo``, ``bench``),
``--map`` of every command that makes, serves or plays scenarios, ``--classes`` and
``--json`` (one meaning everywhere: machine-readable output instead of the human lines).

Choices are spelled out here (not imported from ``agent``) so ``scenweave --help`` does not
load LangGraph; ``pipeline_settings`` turns the options into settings and checks them.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from scenweave.pipeline import PipelineSettings

#: the built-in ``--llm`` choices of every command that runs the agent (run, submit, demo,
#: bench); a plugin's backend (``docs/plugins.md``) is a choice too
LLM_CHOICES = ("auto", "embedded", "ollama", "replay", "none")


class LlmChoice(click.Choice):
    """``--llm``: a built-in choice, or the name of a plugin's backend. The plugins are asked
    only when a name is not built in, so ``--help`` and the usual names load no plugin."""

    name = "llm"

    def __init__(self) -> None:
        super().__init__(LLM_CHOICES)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "[" + "|".join(LLM_CHOICES) + "|PLUGIN]"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        if value in LLM_CHOICES:
            return value
        from scenweave.agent.llm.backends import backend_names

        known = backend_names()
        if value in known:
            return value
        choices = ", ".join(dict.fromkeys((*LLM_CHOICES, *known)))
        self.fail(f"{value!r} is not one of {choices}", param, ctx)
SANDBOX_CHOICES = ("auto", "docker", "bwrap")
#: names of the options below, for commands that forward them
AGENT_OPTION_NAMES = ("llm", "model", "repair", "max_attempts", "sandbox", "ollama_host",
                      "llm_timeout", "num_ctx", "max_tokens", "replay_file", "on_llm_error",
                      "replay")

def _option(decls: list[str], **attrs: Any) -> tuple[list[str], dict]:
    return decls, attrs


AGENT_OPTIONS = [
    _option(["--llm"], type=LlmChoice(), default="auto", show_default=True,
            help="LLM backend: auto (the Ollama server when one answers, else the reference "
                 "scripts), embedded (SmolLM2-135M in-process: weak, slow, for trying the "
                 "agent), ollama, replay (recorded replies), none (= --no-llm), or a "
                 "plugin's backend (docs/plugins.md)."),
    _option(["--model"], help="Model: an Ollama tag (default qwen2.5-coder:7b) or a GGUF "
                                   "file for --llm embedded (default SmolLM2-135M-Instruct)."),
    _option(["--repair"], default="error-feedback", show_default=True,
                 help="Repair strategy: error-feedback, code-corrections or patch."),
    _option(["--max-attempts"], default=3, show_default=True, type=click.IntRange(1),
                 help="LLM attempts before the reference script is used (fallback)."),
    _option(["--sandbox"], type=click.Choice(SANDBOX_CHOICES), default="auto",
                 show_default=True, help="Where LLM-written code runs."),
    _option(["--ollama-host"], envvar="OLLAMA_HOST", show_envvar=True,
                 help="Ollama server [default: http://localhost:11434]."),
    _option(["--llm-timeout"], default=300.0, show_default=True, type=click.FloatRange(1),
                 help="Seconds one LLM call may take."),
    _option(["--num-ctx"], default=8192, show_default=True, type=click.IntRange(512),
                 help="Context window asked of the model."),
    _option(["--max-tokens"], type=click.IntRange(16),
            help="Output tokens per call [default: 4096 Ollama, 1024 embedded]."),
    _option(["--replay-file"], type=click.Path(exists=True, dir_okay=False, path_type=Path),
                 help="For --llm replay: a replies JSON or a scenario's trace.jsonl."),
    _option(["--replay/--no-replay"], default=None,
                 help="Play every scenario headless in esmini and judge it against the record "
                      "[default: on when esmini is found, see scenweave doctor]."),
    _option(["--on-llm-error"], type=click.Choice(["raise", "fallback"]), default="raise",
                 show_default=True,
                 help="LLM unreachable or too slow: stop the run, or use the fallback."),
]


MAP_HELP = ("Map: a bundled CARLA town (Town01, Town02, Town04, Town06, Town07, Town10HD) or a "
            "path to an OpenDRIVE .xodr file; its spawn database is built on first use and "
            "cached in $SCENWEAVE_HOME  [default: Town04]")


def map_option(optional: bool = False, help: str = MAP_HELP
               ) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--map NAME|FILE.xodr``, passed to the command as ``map_ref``: the
    ``roads.MapRef`` it names (not given: Town04, or None when ``optional``)."""
    def resolve(ctx: click.Context, param: click.Parameter, value: str | None) -> Any:
        if value is None and optional:
            return None
        from scenweave.roads import UnknownMapError, resolve_map

        try:
            return resolve_map(value)
        except UnknownMapError as err:
            raise click.BadParameter(str(err), ctx=ctx, param=param) from err

    return click.option("--map", "map_ref", metavar="NAME|FILE.xodr", callback=resolve,
                        help=help)


def json_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--json`` (passed as ``as_json``): print ``what`` as JSON instead of the human lines."""
    return click.option("--json", "as_json", is_flag=True,
                        help=f"Print {what} as JSON instead of the human lines.")


def class_codes(ctx: click.Context, param: click.Parameter, value: str | None
                ) -> tuple[str, ...]:
    """``--classes BRAKE,CINF`` as codes, each a registered class: a typo is a usage error
    before anything is written (an unknown class would silently select nothing)."""
    from scenweave import maneuvers

    codes = tuple(c.strip().upper() for c in (value or "").split(",") if c.strip())
    unknown = [c for c in codes if maneuvers.find(c) is None]
    if unknown:
        raise click.BadParameter(f"unknown class {', '.join(unknown)} (known: "
                                 f"{', '.join(maneuvers.codes())})", ctx=ctx, param=param)
    return codes


def agent_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add every agent option to a click command function."""
    for decls, attrs in reversed(AGENT_OPTIONS):
        command = click.option(*decls, **attrs)(command)
    return command


def pipeline_settings(no_llm: bool, top_n: int, llm: str = "none", model: str | None = None,
                      repair: str = "error-feedback", max_attempts: int = 3,
                      sandbox: str = "auto", ollama_host: str | None = None,
                      llm_timeout: float = 300.0, num_ctx: int = 8192,
                      max_tokens: int | None = None, replay_file: Path | None = None,
                      on_llm_error: str = "raise", replay: bool | None = None,
                      map_ref: Any = None) -> PipelineSettings:
    """Pipeline settings from the options; ``--no-llm`` or ``--llm none`` = reference scripts;
    ``map_ref`` (``--map``) is the map scenarios are made for (None: Town04)."""
    plan = replay_plan_for(replay)
    replay_settings = plan.settings
    map_name = None if map_ref is None else map_ref.logic_file
    _check_repair(repair)  # a bad option is a usage error whichever LLM runs
    if llm == "replay" and replay_file is None:
        raise click.UsageError("--llm replay needs --replay-file")
    if llm == "auto" and not no_llm:
        llm = auto_llm(ollama_host)
    if no_llm or llm == "none":
        return PipelineSettings(no_llm=True, top_n=top_n, replay=replay_settings, map=map_name,
                                replay_not_run=plan.not_run_because)
    from scenweave.agent import AgentSettings
    from scenweave.agent.settings import batch_sandbox

    agent = AgentSettings(llm=llm, model=model, repair=repair.replace("-", "_"),
                          max_attempts=max_attempts, timeout_s=llm_timeout, num_ctx=num_ctx,
                          max_tokens=max_tokens, ollama_host=ollama_host,
                          replay_file=replay_file, on_llm_error=on_llm_error,
                          sandbox=batch_sandbox(sandbox), replay=replay_settings)
    return PipelineSettings(no_llm=False, top_n=top_n, agent=agent, replay=replay_settings,
                            map=map_name, replay_not_run=plan.not_run_because)


def _check_repair(repair: str) -> None:
    from scenweave.agent.repair import checked_repair

    try:
        checked_repair(repair)
    except ValueError as err:
        raise click.BadParameter(str(err), param_hint="--repair") from err


def replay_settings_for(wanted: bool | None) -> Any:
    """``ReplaySettings`` when scenarios are to be played: asked for (``--replay``: esmini must
    be there), or by default when esmini is found; None for ``--no-replay``."""
    return replay_plan_for(wanted).settings


def replay_plan_for(wanted: bool | None) -> Any:
    """``scenweave.unplayed.replay_plan``: the settings, and why scenarios are not played
    (``--replay`` without esmini is a usage error naming ESMINI_HOME)."""
    from scenweave.player import PlayerUnavailable
    from scenweave.unplayed import replay_plan

    try:
        return replay_plan(wanted)
    except PlayerUnavailable as err:
        raise click.UsageError(f"--replay: {err}") from err


def echo_not_played(summary: dict, run_dir: Path) -> None:
    """The one line saying how many of a run's scenarios were not played in esmini, why and
    what to do (``scenweave.unplayed.not_played_line``); nothing when all were."""
    from scenweave.unplayed import not_played_line

    line = not_played_line(summary, run_dir)
    if line:
        click.echo(line, err=True)


def auto_llm(ollama_host: str | None) -> str:
    """``--llm auto``: ``ollama`` when its server answers (the production path), else ``none``
    with one line saying so and how to get an LLM."""
    from scenweave.agent.llm.ollama import server_answers
    from scenweave.agent.settings import DEFAULT_OLLAMA_HOST

    host = ollama_host or DEFAULT_OLLAMA_HOST
    if server_answers(host):
        return "ollama"
    click.echo(f"llm: no Ollama server answers at {host}: running the reference scripts "
               "(start one or set OLLAMA_HOST; --llm embedded tries the built-in SmolLM2)",
               err=True)
    return "none"

"""The ``scenweave`` command line.

Each subcommand lives in its own module under ``scenweave/commands/`` and is imported only
when it runs, so ``scenweave --help`` stays fast and one broken extra never breaks the rest.
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import os
import sys
import threading
from typing import NoReturn

import click

from scenweave import __version__, exit_codes
from scenweave.run_folder import RunInterrupted

#: subcommand name -> "module:attribute" of its click command
COMMANDS: dict[str, str] = {
    "sample-data": "scenweave.commands.sample_data:sample_data",
    "ingest": "scenweave.commands.ingest:ingest",
    "mine": "scenweave.commands.mine:mine",
    "demo": "scenweave.commands.demo:demo",
    "run": "scenweave.commands.run:run",
    "validate": "scenweave.commands.validate:validate",
    "spawn-db": "scenweave.commands.spawn_db:spawn_db",
    "sandbox": "scenweave.commands.sandbox:sandbox",
    "worker": "scenweave.commands.worker:worker",
    "submit": "scenweave.commands.submit:submit_command",
    "collect": "scenweave.commands.collect:collect",
    "report": "scenweave.commands.report:report",
    "bench": "scenweave.commands.bench:bench",
    "trace": "scenweave.commands.trace:trace",
    "logs": "scenweave.commands.logs:logs",
    "doctor": "scenweave.commands.doctor:doctor",
    "replay": "scenweave.commands.replay:replay",
    "view": "scenweave.commands.view:view",
    "export": "scenweave.commands.export:export",
}


class LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        target = COMMANDS.get(name)
        if target is None:
            return None
        module_name, attr = target.split(":")
        return getattr(importlib.import_module(module_name), attr)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="scenweave")
@click.option("--verbose", "-v", is_flag=True, help="Show the full traceback on errors.")
@click.pass_context
def cli(ctx: click.Context, verbose: bool) -> None:
    """ScenWeave: driving records in, validated OpenSCENARIO 1.0 scenarios for CARLA out."""
    ctx.obj = {"verbose": verbose}


def main(argv: list[str] | None = None) -> None:
    """Console entry point: user errors become one line; ``--verbose`` (before or after the
    subcommand) shows the traceback. Exit codes: ``scenweave.exit_codes``.

    Called as the program (``argv`` None) it leaves by :func:`_leave`, without the
    interpreter's teardown; called with ``argv`` (tests, scripts) it raises ``SystemExit``."""
    if argv is not None:
        _main(argv)
    try:
        _main(sys.argv[1:])
    except SystemExit as done:
        _leave(done)


def _leave(done: SystemExit) -> NoReturn:
    """End the program with ``done``'s code once the exit handlers have run (the player
    server stopped, logs and pools shut) and the console is flushed, skipping the teardown
    of every module and object: 0.3-0.5 s after a run's report was written (scipy,
    scenariogeneration and the map's lane graph freed one by one) that nobody waits for.
    With another thread still working, Python's own exit waits for it as usual."""
    if any(t.is_alive() and not t.daemon for t in threading.enumerate()
           if t is not threading.main_thread()):
        raise done
    code = done.code
    if not isinstance(code, int):
        if code is not None:
            print(code, file=sys.stderr)
        code = 0 if code is None else 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    os._exit(code)


def _main(argv: list[str]) -> NoReturn:
    """``main``'s work: the command, its errors as one line, ``SystemExit`` with the code."""
    args = _verbose_first(argv)
    verbose = args[:1] == ["--verbose"] or "-v" in args[:1]
    try:
        # without standalone mode click returns an Exit's code instead of exiting with it
        code = cli.main(args=args, prog_name="scenweave", standalone_mode=False)
        sys.exit(code if isinstance(code, int) else exit_codes.DELIVERED)
    except click.exceptions.Exit as exit_:
        sys.exit(exit_.exit_code)
    except click.ClickException as err:
        err.show()
        sys.exit(err.exit_code)
    except (click.Abort, KeyboardInterrupt) as err:
        # click turns Ctrl-C into Abort; a run's own interruption says how to resume
        cause = err.__cause__ if isinstance(err, click.Abort) else err
        click.echo(str(cause) if isinstance(cause, RunInterrupted) else "interrupted", err=True)
        sys.exit(exit_codes.INTERRUPTED)
    except Exception as err:  # noqa: BLE001 - the one place that turns crashes into a line
        if verbose:
            raise
        # a note says what became of the work (a stopped run: which, where, how to resume)
        notes = "".join(f"; {note}" for note in getattr(err, "__notes__", ()))
        click.echo(f"error: {type(err).__name__}: {err} (run with --verbose for the traceback)"
                   f"{notes}", err=True)
        sys.exit(exit_codes.PROBLEMS)


def _verbose_first(args: list[str]) -> list[str]:
    """``scenweave run DATA --verbose`` as ``scenweave --verbose run DATA``: the flag is the
    group's, but users type it anywhere (not after ``--``)."""
    end = args.index("--") if "--" in args else len(args)
    if "--verbose" not in args[:end]:
        return args
    return ["--verbose", *(a for i, a in enumerate(args) if a != "--verbose" or i >= end)]


if __name__ == "__main__":
    main()

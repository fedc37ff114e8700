"""``--where EXPR`` of ``mine`` and ``run``: the record filter, parsed when the command line
is read, so a malformed expression is a usage error (exit 2) before anything is written."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from scenweave.mining.where import Where, WhereError, parse_where

HELP = ("Only records this expression matches, e.g. \"ttc_min_s < 2 and maneuver_class in "
        "(CINF, CINB)\": comparisons (< <= > >= == !=), in (...), not in, and/or/not, "
        "parentheses (docs/mining.md, 'Choosing records').")


def parsed_where(ctx: click.Context, param: click.Parameter, value: str | None) -> Where | None:
    """The parsed expression; one line naming the column and what was expected, else."""
    if value is None:
        return None
    try:
        return parse_where(value)
    except WhereError as err:
        raise click.BadParameter(str(err), ctx=ctx, param=param) from err


def where_option() -> Callable[[Any], Any]:
    """The ``--where`` option, its value a :class:`Where` (or None)."""
    return click.option("--where", "where", callback=parsed_where, metavar="EXPR", help=HELP)

"""Repair strategies, selectable by name (``--repair``). Adding one is one module in this
package that defines ``STRATEGY``, an instance of :class:`agent.repair.base.RepairStrategy`."""

from __future__ import annotations

import importlib
import pkgutil

from scenweave.agent.repair.base import Candidate, RepairStrategy, Request

__all__ = ["Candidate", "RepairStrategy", "Request", "checked_repair", "get_strategy",
           "strategy_names"]

_NOT_STRATEGIES = {"base"}


def strategy_names() -> list[str]:
    """Every strategy module in this package, e.g. ``code_corrections``, ``error_feedback``."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__)
                  if m.name not in _NOT_STRATEGIES and not m.name.startswith("_"))


def checked_repair(name: str) -> str:
    """``name`` as a strategy module name (``patch``, ``error_feedback``); a ValueError naming
    ``--repair`` and the choices when there is no such strategy."""
    module_name = name.replace("-", "_")
    names = strategy_names()
    if module_name not in names:
        choices = ", ".join(n.replace("_", "-") for n in names)
        raise ValueError(f"--repair {name!r}: no such repair strategy (choose {choices})")
    return module_name


def get_strategy(name: str) -> RepairStrategy:
    """The strategy called ``name`` (dashes and underscores alike); ValueError if none is."""
    return importlib.import_module(f"scenweave.agent.repair.{checked_repair(name)}").STRATEGY

"""Repair strategies, selectable by name (``--repair``): one registry, asked by the settings
and the graph. The built-in ones are declared below exactly as a plugin declares its own
(``REPAIR_STRATEGIES``, name -> a :class:`agent.repair.base.RepairStrategy` or
``"module:attribute"``; ``docs/plugins.md``)."""

from __future__ import annotations

from scenweave.agent.repair.base import Candidate, RepairStrategy, Request
from scenweave.plugins import DOCS, Registry

__all__ = ["REPAIR_STRATEGIES", "Candidate", "RepairStrategy", "Request", "checked_repair",
           "get_strategy", "strategy_names"]

REPAIR_STRATEGIES = {
    "code_corrections": "scenweave.agent.repair.code_corrections:STRATEGY",
    "error_feedback": "scenweave.agent.repair.error_feedback:STRATEGY",
    "patch": "scenweave.agent.repair.patch:STRATEGY",
}


def _module_style(name: str) -> str:
    """``error-feedback`` and ``error_feedback`` are one strategy."""
    return name.replace("-", "_")


_strategies: Registry[RepairStrategy] = Registry(
    "repair strategy", "REPAIR_STRATEGIES", expected="a RepairStrategy",
    accepts=lambda thing: isinstance(thing, RepairStrategy), normalize=_module_style,
    builtin_modules=[__name__])


def strategy_names() -> list[str]:
    """Every strategy's name, e.g. ``code_corrections``, ``error_feedback``, a plugin's."""
    return _strategies.names()


def checked_repair(name: str) -> str:
    """``name`` as a strategy's registered name (``patch``, ``error_feedback``); a ValueError
    naming ``--repair`` and the choices when there is no such strategy."""
    get_strategy(name)
    return _module_style(name)


def get_strategy(name: str) -> RepairStrategy:
    """The strategy called ``name`` (dashes and underscores alike); ValueError if none is."""
    found = _strategies.find(name)
    if found is None:
        choices = ", ".join(n.replace("_", "-") for n in strategy_names())
        raise ValueError(f"--repair {name!r}: no such repair strategy (choose {choices}; "
                         f"plugins add more, see {DOCS})")
    return found

"""The agent: a LangGraph StateGraph that retrieves a reference script, has a local LLM adapt
it to a record's params, runs the result in a sandbox, validates it, repairs it, and falls
back to the reference script when attempts run out. See ``agent/graph.py``.

``run_scenario(params, out_dir, AgentSettings(...))`` -> :class:`AgentOutcome`.

The names below load on first use, so ``agent.trace`` (the scenario folder's event log,
shared with the ``--no-llm`` path) can be imported without loading LangGraph.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "LLMTimeout": "scenweave.agent.llm.base", "LLMUnavailable": "scenweave.agent.llm.base",
    "AgentOutcome": "scenweave.agent.run", "close_shared": "scenweave.agent.run",
    "run_scenario": "scenweave.agent.run",
    "AgentSettings": "scenweave.agent.settings",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'scenweave.agent' has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)

"""The typed state of one scenario's run through the graph (checkpointed per scenario).

Everything here is plain JSON data, so the SQLite checkpointer can store every step and a
trace can be read back without ScenWeave's classes. Runtime objects (the LLM, the sandbox,
the settings) live in :class:`agent.context.AgentContext`, not in the state.
"""

from __future__ import annotations

from typing import Annotated, TypedDict

from scenweave.schemas.params import Params


def add_seconds(left: dict[str, float], right: dict[str, float]) -> dict[str, float]:
    """Reducer of ``node_latency_s``: seconds per node add up over repeated visits."""
    merged = dict(left or {})
    for node, seconds in (right or {}).items():
        merged[node] = round(merged.get(node, 0.0) + seconds, 4)
    return merged


class Attempt(TypedDict, total=False):
    """One LLM attempt: what was asked, answered, run and found."""

    number: int
    """1 for the first generation, 2.. for repairs."""
    made_by: str
    """The node that made it: ``generate`` or ``repair``."""
    strategy: str
    """The repair strategy in charge (its name)."""
    prompt: dict | None
    """The system and user text sent to the LLM (None when no LLM was asked)."""
    reply: str | None
    """The LLM's raw reply."""
    tokens_in: int
    tokens_out: int
    llm_latency_s: float
    extraction: dict
    """How the code was found in the reply: method and warnings."""
    corrections: list[str]
    """Deterministic corrections applied to the code (thesis §5.3)."""
    code: str
    """The script that was (or would have been) run."""
    diff: str
    """Unified diff from the reference script to ``code``."""
    execution: dict | None
    """The sandbox's ExecResult (None when the code never reached the sandbox)."""
    validation: dict | None
    """validate_xosc's verdict on the produced file."""
    error: dict | None
    """Why the attempt failed: type, message, traceback (None while it has not failed)."""
    llm_failed: bool
    """The LLM could not be asked (an ``LLMUnavailable`` caught, with ``on_llm_error``
    ``fallback``): the graph goes straight to the fallback."""
    taxonomy: str | None
    """One word for the failure (agent.taxonomy.CATEGORIES)."""


class AgentState(TypedDict, total=False):
    """What the graph knows about one scenario at each step."""

    params: Params
    """The scenario's params with its spawn: the values the script must reproduce."""
    out_dir: str
    """This scenario's folder; attempts write into ``attempts/<n>/`` below it."""
    reference: dict
    """The retrieved reference script: name, path, retrieval method, source."""
    attempts: list[Attempt]
    """Every LLM attempt so far, in order; the last one is the current one."""
    final: dict
    """Set when the graph ends: status, which attempt produced the file, its validation."""
    node_latency_s: Annotated[dict[str, float], add_seconds]
    """Seconds spent in each node, summed over repeated visits."""

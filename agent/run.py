"""Running the agent on one scenario: ``run_scenario(params, out_dir, settings)``.

Each scenario is one LangGraph thread (``thread_id = scenario_id``) checkpointed in
``<scenario>/checkpoints.sqlite`` after every node, beside the readable ``trace.jsonl``;
both move with the scenario folder when it is committed. The LLM and the sandbox are made
once per process and settings, and reused by every scenario of a batch.
"""

from __future__ import annotations

import atexit
import json
import sqlite3
import threading
from collections import Counter
from contextlib import closing, suppress
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from scenweave.agent.context import AgentContext
from scenweave.agent.graph import build_graph
from scenweave.agent.llm import LLM, get_llm
from scenweave.agent.repair import get_strategy
from scenweave.agent.settings import AgentSettings
from scenweave.agent.state import AgentState
from scenweave.agent.trace import Trace
from scenweave.sandbox import Sandbox, get_sandbox
from scenweave.schemas.params import Params
from scenweave.schemas.scenario_folder import CHECKPOINTS_NAME, TRACE_NAME

if TYPE_CHECKING:
    from langchain_core.runnables import RunnableConfig

#: graph steps allowed per scenario: retrieve + (generate|repair, execute, validate) x attempts
#: + fallback, with room to spare
STEPS_PER_ATTEMPT = 3


@dataclass
class AgentOutcome:
    """What the agent did for one scenario (merged into its ``status.json``)."""

    status: str
    attempts: int
    first_attempt_success: bool
    fallback: bool
    tokens_in: int
    tokens_out: int
    error_taxonomy: list[str]
    error: str | None
    validation: dict | None
    retrieval: str | None
    llm: dict
    repair: str
    node_latency_s: dict[str, float] = field(default_factory=dict)
    corrections: list[str] = field(default_factory=list)
    replay: dict | None = None

    def to_dict(self) -> dict:
        return asdict(self)


def run_scenario(params: Params, out_dir: Path, settings: AgentSettings,
                 trace: Trace | None = None) -> AgentOutcome:
    """Make one scenario with the agent in ``out_dir``; raise only infrastructure errors.

    Events go to ``trace`` (the pipeline's, so times count from the scenario's start) or to
    a new ``out_dir/trace.jsonl``.
    """
    out_dir = Path(out_dir)
    context = AgentContext(settings=settings, llm=shared_llm(settings),
                           sandbox=shared_sandbox(settings),
                           strategy=get_strategy(settings.repair),
                           trace=trace or Trace(out_dir / TRACE_NAME))
    thread: RunnableConfig = {"configurable": {"thread_id": params["scenario_id"]},
              "recursion_limit": 4 + STEPS_PER_ATTEMPT * settings.max_attempts + 2}
    with closing(sqlite3.connect(out_dir / CHECKPOINTS_NAME, check_same_thread=False)) as db:
        from langgraph.checkpoint.sqlite import SqliteSaver

        graph = build_graph().compile(checkpointer=SqliteSaver(db))
        start: AgentState = {"params": params, "out_dir": str(out_dir)}
        state = graph.invoke(start, thread, context=context)
    return outcome_of(state, settings)


def outcome_of(state: dict, settings: AgentSettings) -> AgentOutcome:
    """The outcome a final graph state describes."""
    attempts = state.get("attempts") or []
    final = state.get("final") or {"status": "failed", "validation": None}
    failed = [a for a in attempts if a.get("error") is not None]
    last_error = failed[-1]["error"] if failed else None
    error = final.get("error")
    if error is None and final["status"] != "ok" and last_error:
        error = f"{last_error.get('type')}: {str(last_error.get('message', ''))[:300]}"
    return AgentOutcome(
        status=final["status"],
        attempts=len(attempts),
        first_attempt_success=final["status"] == "ok",
        fallback=final["status"] in ("fallback", "failed") and final.get("attempt") is None,
        tokens_in=sum(a.get("tokens_in", 0) for a in attempts),
        tokens_out=sum(a.get("tokens_out", 0) for a in attempts),
        error_taxonomy=[a["taxonomy"] for a in failed if a.get("taxonomy")]
        + ([final["taxonomy"]] if final.get("taxonomy") else []),
        error=error,
        validation=final.get("validation"),
        retrieval=(state.get("reference") or {}).get("method"),
        llm={"backend": settings.llm, "model": settings.model_name},
        repair=settings.repair,
        node_latency_s=state.get("node_latency_s") or {},
        corrections=sorted(Counter(c for a in attempts for c in a.get("corrections", []))),
        replay=(final.get("validation") or {}).get("replay"),
    )


# --- one LLM and one sandbox per process and settings ---------------------------------------

_shared: dict[str, Any] = {}
_shared_lock = threading.Lock()


def _key(kind: str, settings: AgentSettings) -> str:
    return kind + json.dumps(settings.to_dict(), sort_keys=True, default=str)


def shared_llm(settings: AgentSettings) -> LLM:
    """The LLM of ``settings``, made and checked once per process."""
    return _shared_instance(_key("llm", settings), lambda: _checked(_for_run(get_llm(settings),
                                                                             settings)))


def shared_sandbox(settings: AgentSettings) -> Sandbox:
    """The sandbox of ``settings.sandbox``, started once per process."""
    key = "sandbox" + json.dumps(asdict(settings.sandbox), sort_keys=True, default=str)
    return _shared_instance(key, lambda: get_sandbox(settings.sandbox))


def _for_run(llm: LLM, settings: AgentSettings) -> LLM:
    llm.run_id = settings.run_id
    return llm


def _checked(llm: LLM) -> LLM:
    llm.check()
    return llm


def _shared_instance(key: str, make: Any) -> Any:
    with _shared_lock:
        if key not in _shared:
            _shared[key] = make()
        return _shared[key]


@atexit.register
def close_shared() -> None:
    """Close every shared LLM and sandbox (also called by tests between settings)."""
    with _shared_lock:
        items = list(_shared.values())
        _shared.clear()
    for item in items:
        with suppress(Exception):  # closing at exit must not mask the real error
            item.close()

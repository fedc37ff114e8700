"""The graph's nodes. Each takes the state and the runtime context, returns a state update
and writes one event to the scenario's readable trace (``trace.jsonl``)."""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from langgraph.runtime import Runtime

from scenweave.agent.code import diff_to_reference, static_check
from scenweave.agent.context import AgentContext
from scenweave.agent.llm.base import LLMTimeout, LLMUnavailable
from scenweave.agent.repair.base import Candidate, Request
from scenweave.agent.state import AgentState, Attempt
from scenweave.agent.taxonomy import classify_exception
from scenweave.judge.findings import failure_category
from scenweave.schemas.scenario_folder import ATTEMPTS_DIR, CODE_NAME, XOSC_NAME

#: how a replay failure is put to the LLM: what the engine showed against what the record says
REPLAY_LEAD = ("The file is valid, but played in the esmini OpenSCENARIO engine it does not do "
               "what the record did (each line: when, what happened, what the record says): ")
NodeBody = Callable[[AgentState, AgentContext], tuple[dict, dict]]


class GraphNode(Protocol):
    """A node as langgraph calls it: the state, and the runtime by keyword."""

    __name__: str

    def __call__(self, state: AgentState, runtime: Runtime[AgentContext]) -> dict: ...


def node(body: NodeBody) -> GraphNode:
    """Make ``body`` a graph node of the same name: timed, and traced with its event."""

    def run(state: AgentState, runtime: Runtime[AgentContext]) -> dict:
        started = time.perf_counter()
        update, event = body(state, runtime.context)
        took = round(time.perf_counter() - started, 4)
        runtime.context.trace.event(body.__name__, duration_s=took, **event)
        return {**update, "node_latency_s": {body.__name__: took}}

    run.__name__ = run.__qualname__ = body.__name__
    run.__doc__ = body.__doc__
    return run


@node
def retrieve(state: AgentState, ctx: AgentContext) -> tuple[dict, dict]:
    """Pick the reference script for the manoeuvre (keyword, tag, semantic fallback)."""
    from scenweave import corpus
    from scenweave.corpus.worked_example import adaptation

    found = corpus.retrieve(state["params"])
    example, values = adaptation(found.script_path, state["params"])
    reference = {"name": found.script_path.name, "path": str(found.script_path),
                 "method": found.method, "source": found.source, "example": example,
                 "values": values}
    return {"reference": reference, "attempts": []}, {"script": reference["name"],
                                                      "method": found.method}


@node
def generate(state: AgentState, ctx: AgentContext) -> tuple[dict, dict]:
    """First attempt: the strategy asks the LLM for a script adapted to the params."""
    return _new_attempt(state, ctx, "generate", ctx.strategy.generate)


@node
def repair(state: AgentState, ctx: AgentContext) -> tuple[dict, dict]:
    """A new attempt after a failure, made the way the chosen strategy repairs."""
    return _new_attempt(state, ctx, "repair", ctx.strategy.repair)


@node
def execute(state: AgentState, ctx: AgentContext) -> tuple[dict, dict]:
    """Run the attempt's code in the sandbox (after a compile-only check on the host), given
    only the record's provenance: the values are the ones the LLM wrote in."""
    attempt = state["attempts"][-1].copy()
    if attempt.get("error") is None:
        problem = static_check(attempt.get("code", ""))
        if problem is not None:
            _fail(attempt, {"type": problem.error_type, "message": problem.message,
                            "line": problem.line})
        else:
            _run_in_sandbox(attempt, state, ctx)
    event = {"attempt": attempt["number"], "sandbox": attempt.get("execution"),
             "error": attempt.get("error"), "taxonomy": attempt.get("taxonomy")}
    return {"attempts": _replace_last(state, attempt)}, event


@node
def validate(state: AgentState, ctx: AgentContext) -> tuple[dict, dict]:
    """Check the attempt's file: XSD, Table 5.8, semantics, parameter fidelity, CARLA lint,
    and (with replay settings) what it does when played; a replay failure is repairable."""
    from scenweave.judge import validate_xosc

    attempt = state["attempts"][-1].copy()
    out_dir = Path(state["out_dir"])
    produced = out_dir / ATTEMPTS_DIR / str(attempt["number"]) / XOSC_NAME
    result = validate_xosc(produced, state["params"], replay=ctx.settings.replay)
    result.write_replay(produced.parent)
    verdict = _validation_summary(result.to_dict())
    attempt["validation"] = verdict
    update: dict[str, Any] = {}
    if verdict["valid"]:
        result.write_replay(out_dir)
        shutil.copyfile(produced, out_dir / XOSC_NAME)
        (out_dir / CODE_NAME).write_text(attempt["code"], encoding="utf-8")
        status = "ok" if attempt["number"] == 1 else "repaired"
        update["final"] = {"status": status, "attempt": attempt["number"], "validation": verdict}
    else:
        category = failure_category(verdict["errors"])
        _fail(attempt, {"type": "ReplayError" if category == "replay" else "ValidationError",
                        "message": REPLAY_LEAD * (category == "replay")
                        + _errors_text(verdict["errors"])}, category)
    update["attempts"] = _replace_last(state, attempt)
    return update, {"attempt": attempt["number"], **verdict, "taxonomy": attempt.get("taxonomy")}


@node
def fallback(state: AgentState, ctx: AgentContext) -> tuple[dict, dict]:
    """Out of attempts: run the reference script directly (trusted code, in-process)."""
    from scenweave import corpus
    from scenweave.judge import validate_xosc

    out_dir = Path(state["out_dir"])
    xosc = out_dir / XOSC_NAME
    reference = state.get("reference") or {}
    try:
        corpus.generate(state["params"], xosc)
    except Exception as err:  # noqa: BLE001 - a params problem fails this scenario only
        final: dict[str, Any] = {"status": "failed", "attempt": None, "validation": None,
                                 "error": f"{type(err).__name__}: {err}"}
        return {"final": final}, {"script": reference.get("name"), **final}
    (out_dir / CODE_NAME).write_text(reference.get("source", ""), encoding="utf-8")
    result = validate_xosc(xosc, state["params"], replay=ctx.settings.replay)
    result.write_replay(out_dir)
    verdict = _validation_summary(result.to_dict())
    final = {"status": "fallback" if verdict["valid"] else "failed", "attempt": None,
             "validation": verdict,
             "error": None if verdict["valid"] else _errors_text(verdict["errors"]),
             "taxonomy": None if verdict["valid"] else failure_category(verdict["errors"])}
    return {"final": final}, {"script": reference.get("name"), **final}


# --- helpers ------------------------------------------------------------------------------

def _new_attempt(state: AgentState, ctx: AgentContext, node_name: str,
                 make: Callable[[Request, Any], Candidate]) -> tuple[dict, dict]:
    attempts = list(state.get("attempts") or [])
    attempt: Attempt = {"number": len(attempts) + 1, "made_by": node_name,
                        "strategy": ctx.strategy.name, "execution": None, "validation": None,
                        "error": None, "taxonomy": None}
    reference = state["reference"]
    request = Request(state["params"], _adapted(reference), attempts, reference.get("values"))
    try:
        candidate = make(request, ctx.llm)
    except LLMUnavailable as err:
        if ctx.settings.on_llm_error == "raise":
            raise
        candidate = Candidate("", error={"type": type(err).__name__, "message": str(err)})
        attempt["taxonomy"] = "timeout" if isinstance(err, LLMTimeout) else "llm_unavailable"
        attempt["llm_failed"] = True
    attempt.update(_describe(candidate, state["reference"]))
    if candidate.error is not None:
        _fail(attempt, candidate.error, attempt.get("taxonomy"))
    event = {k: v for k, v in attempt.items() if k not in ("execution", "validation")}
    return {"attempts": [*attempts, attempt]}, event


def _adapted(reference: dict) -> str:
    """What the LLM adapts: the worked example (the reference in older checkpoints)."""
    return reference.get("example") or reference["source"]


def _describe(candidate: Candidate, reference: dict) -> Attempt:
    prompt, reply = candidate.prompt, candidate.reply
    return {
        "prompt": {"system": prompt.system, "user": prompt.user} if prompt else None,
        "reply": reply.text if reply else None,
        "tokens_in": reply.tokens_in if reply else 0,
        "tokens_out": reply.tokens_out if reply else 0,
        "llm_latency_s": reply.latency_s if reply else 0.0,
        "extraction": candidate.extraction,
        "corrections": candidate.corrections,
        "code": candidate.code,
        "diff": diff_to_reference(_adapted(reference), candidate.code,
                                  f"worked example of corpus/{reference['name']}", "attempt"),
    }


def _run_in_sandbox(attempt: Attempt, state: AgentState, ctx: AgentContext) -> None:
    from scenweave.corpus.worked_example import provenance

    out_dir = Path(state["out_dir"])
    attempt_dir = out_dir / ATTEMPTS_DIR / str(attempt["number"])
    result = ctx.sandbox.run(attempt["code"], provenance(state["params"]), attempt_dir)
    execution = result.to_dict()
    execution["files"] = [str(Path(f).relative_to(out_dir)) for f in result.files]
    attempt["execution"] = execution
    if not result.ok:
        _fail(attempt, {"type": result.error_type or "NonZeroExit",
                        "message": result.error_message or "",
                        "traceback": result.traceback})
    elif not (attempt_dir / XOSC_NAME).is_file():
        _fail(attempt, {"type": "NoOutput",
                        "message": f"generate() returned but wrote no {XOSC_NAME}"})


def _fail(attempt: Attempt, error: dict, taxonomy: str | None = None) -> None:
    attempt["error"] = {k: v for k, v in error.items() if v is not None}
    attempt["taxonomy"] = taxonomy or classify_exception(error.get("type"), error.get("message"))


def _replace_last(state: AgentState, attempt: Attempt) -> list[Attempt]:
    return [*state["attempts"][:-1], attempt]


def _validation_summary(result: dict) -> dict:
    errors = [e for e in result["errors"] if e.get("severity") == "error"]
    return {"valid": result["valid"], "fixes_applied": result.get("fixes_applied", []),
            "errors": errors[:20], "domain": result.get("domain"), "replay": result.get("replay")}


def _errors_text(errors: list[dict]) -> str:
    return "; ".join(f"{e['code']}" + (f" (line {e['line']})" if e.get("line") else "")
                     + f": {e.get('message', '')}" for e in errors[:10])

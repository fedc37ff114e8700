"""One scenario, start to finish: spawn -> scenario (reference script or agent) -> validate.

``process_scenario`` is what both ``scenweave run`` and the queue worker call for each
scenario; it never raises for a problem of the scenario itself — that becomes a ``failed``
outcome with the error — so a batch always goes on. Failures of the machine or a service
(``is_infrastructure_error``) are raised instead: the scenario is not at fault, a retry later
may succeed, and the queue worker retries exactly these.
"""

from __future__ import annotations

import json
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from scenweave.agent.trace import Trace
from scenweave.errors import InfrastructureError, ParamsError
from scenweave.schemas.params import Params
from scenweave.schemas.scenario_folder import (
    CODE_NAME,
    PARAMS_NAME,
    TRACE_NAME,
    XOSC_NAME,
    Outcome,
)

if TYPE_CHECKING:
    from scenweave.judge.variation import Asked
    from scenweave.spawn_db.registry import Matcher

__all__ = ["PipelineSettings", "Trace", "process_scenario"]


@dataclass
class PipelineSettings:
    """How scenarios are made: the reference script (``no_llm``) or the agent."""

    no_llm: bool = True
    top_n: int = 5
    agent: Any = None  # agent.AgentSettings when no_llm is False
    #: player.ReplaySettings: play every scenario in esmini and judge it (None: no replay)
    replay: Any = None
    #: why scenarios are not played when ``replay`` is None (``scenweave.unplayed``): run.json
    #: and summary.json say so, and a resumed run with a player plays them
    replay_not_run: str | None = None
    #: the map scenarios are made for: a bundled town's name or an .xodr path (None: Town04)
    map: str | None = None
    #: variants the LLM writes of each delivered scenario (``agent.variants``; agent only)
    vary: int = 0


def process_scenario(params: Params, index: int, out_dir: Path, settings: PipelineSettings,
                     matcher: Matcher) -> dict:
    """Make, validate and describe one scenario in ``out_dir``; return its outcome."""
    started = time.perf_counter()
    timings: dict[str, float] = {}
    trace = Trace(out_dir / TRACE_NAME)
    outcome: dict[str, Any] = {**base_outcome(params)}  # the stages add their keys
    if settings.replay is not None:
        _start_player()
    try:
        placed = _timed(timings, "spawn",
                        lambda: matcher.assign(params, index, top_n=settings.top_n))
        outcome["spawn_id"] = placed.get("spawn_id")
        trace.event("spawn", spawn_id=placed.get("spawn_id"), index=index)
        (out_dir / PARAMS_NAME).write_text(json.dumps(placed, indent=1), encoding="utf-8")
        if settings.no_llm:
            outcome.update(_reference_scenario(placed, out_dir, settings, timings, trace))
        else:
            outcome.update(_agent_scenario(placed, out_dir, settings, timings, trace, matcher))
    except Exception as err:  # noqa: BLE001 - a scenario's failure is a value, not a crash
        if is_infrastructure_error(err):
            trace.event("infrastructure_error", error=f"{type(err).__name__}: {err}")
            raise
        outcome.update(status="failed", error=f"{type(err).__name__}: {err}",
                       error_taxonomy=[_taxonomy_of(err)])
        trace.event("error", error=outcome["error"], traceback=traceback.format_exc())
    timings["total"] = time.perf_counter() - started
    outcome["timings_s"] = {k: round(v, 4) for k, v in timings.items()}
    return outcome


def _start_player() -> None:
    """Start this process's player server now (once; a no-op when it runs), so that it loads
    esmini's library while the scenario is made and checked, not when the replay needs it:
    the first scenario of a run or a worker waited for it."""
    from scenweave.player.engine import warm_up

    warm_up()


def is_infrastructure_error(err: BaseException) -> bool:
    """True when ``err`` is a failure of the machine or a service, not of the scenario: an
    :class:`InfrastructureError` (engine, sandbox, LLM server, queue), an OS error (disk full,
    connection refused) or memory."""
    return isinstance(err, (OSError, MemoryError, InfrastructureError))


def base_outcome(params: Mapping[str, Any]) -> Outcome:
    """The outcome of a scenario before anything ran: ``failed``, no attempts, no spawn."""
    return {
        "scenario_id": params["scenario_id"], "maneuver_class": params["maneuver_class"],
        "domain": params["domain"], "status": "failed", "attempts": 0,
        "first_attempt_success": False, "fallback": False, "spawn_id": None,
        "tokens_in": 0, "tokens_out": 0, "error_taxonomy": [], "error": None,
        "validation": None, "replay": None,
    }


def _reference_scenario(params: Params, out_dir: Path, settings: PipelineSettings,
                        timings: dict, trace: Trace) -> dict:
    from scenweave import corpus
    from scenweave.judge import failure_category, validate_xosc

    retrieval = _timed(timings, "retrieve", lambda: corpus.retrieve(params))
    trace.event("retrieve", script=retrieval.script_path.name, method=retrieval.method)
    (out_dir / CODE_NAME).write_text(retrieval.source, encoding="utf-8")
    xosc = out_dir / XOSC_NAME
    _timed(timings, "generate", lambda: corpus.generate(params, xosc))
    result = _timed(timings, "validate",
                    lambda: validate_xosc(xosc, params, replay=settings.replay))
    result.write_replay(out_dir)
    validation = result.to_dict()
    trace.event("validate", valid=validation["valid"], errors=validation["errors"],
                replay=validation["replay"])
    errors = [e for e in validation["errors"] if e.get("severity") == "error"]
    return {
        "status": "ok" if validation["valid"] else "failed",
        "attempts": 1,  # the reference script, once; no repair without an LLM
        "first_attempt_success": validation["valid"],
        "retrieval": retrieval.method,
        "validation": {"valid": validation["valid"], "fixes_applied": validation["fixes_applied"],
                       "errors": errors[:20], "domain": validation.get("domain")},
        "replay": validation["replay"],
        "error_taxonomy": [] if validation["valid"] else [failure_category(errors)],
        "error": None if validation["valid"] else "; ".join(e["code"] for e in errors[:5]),
    }


def _agent_scenario(params: Params, out_dir: Path, settings: PipelineSettings,
                    timings: dict, trace: Trace, matcher: Matcher) -> dict:
    from scenweave import agent

    result = _timed(timings, "agent",
                    lambda: agent.run_scenario(params, out_dir, settings.agent, trace))
    outcome = result.to_dict()
    if settings.vary and outcome["status"] != "failed":
        from scenweave.agent.variants import make_variants

        outcome["variants"] = _timed(timings, "vary", lambda: make_variants(
            params, asked_variants(params, settings.vary, matcher), out_dir, settings.agent,
            settings.replay, parametric=bool(outcome.get("fallback")), trace=trace))
    return outcome


def asked_variants(placed: Params, count: int, matcher: Matcher) -> list[Asked]:
    """What each of ``count`` variants of a delivered scenario is to play, worked out before
    the agent writes them (``judge.variation.ASPECTS`` in turn): the record as
    ``ingest.variants.vary`` makes it, or why no variant of that aspect can be asked."""
    from scenweave.ingest.variants import NotAsked, vary
    from scenweave.judge.variation import Asked, aspect_of

    asked = []
    for number in range(1, count + 1):
        aspect, round_number = aspect_of(number)
        try:
            asked.append(Asked(aspect, vary(placed, aspect, round_number, matcher)))
        except NotAsked as err:
            asked.append(Asked(aspect, None, f"{err.code}: {err}"))
    return asked


def _timed(timings: dict, name: str, work: Callable[[], Any]) -> Any:
    start = time.perf_counter()
    try:
        return work()
    finally:
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - start


def _taxonomy_of(err: Exception) -> str:
    # imported here: only a failed scenario needs them (and its stages loaded them already)
    from scenweave.spawn_db.errors import NoSpawnFits

    if isinstance(err, NoSpawnFits):
        return "spawn"
    if isinstance(err, ParamsError | KeyError):
        return "params"
    return "other"  # infrastructure errors are raised, never get here

"""Reading a scenario's trace back: find it in the run folders, load its events, show them.

The trace is ``<run>/<scenario>/trace.jsonl`` (one event per node, in order) with the
LangGraph checkpoints of the same thread in ``checkpoints.sqlite`` beside it.
"""

from __future__ import annotations

import sqlite3
from contextlib import closing
from pathlib import Path

from scenweave.errors import InputError
from scenweave.run_folder import safe_name
from scenweave.schemas.scenario_folder import (
    CHECKPOINTS_NAME,
    STATUS_NAME,
    TRACE_NAME,
    read_json_lines,
    read_json_object,
)

PREVIEW_LINES = 12


class TraceNotFound(InputError, LookupError):
    """No run folder holds a trace for the scenario."""


def find_scenario(scenario_id: str, runs_root: Path, run_id: str | None = None) -> Path:
    """The scenario's folder: in run ``run_id``, else in the newest run that has it."""
    name = safe_name(scenario_id)
    runs = [Path(runs_root) / run_id] if run_id else sorted(
        (p for p in Path(runs_root).glob("*") if p.is_dir()), key=lambda p: p.stat().st_mtime,
        reverse=True)
    for run in runs:
        if (run / name / TRACE_NAME).is_file():
            return run / name
    where = f"run {run_id!r} of {runs_root}" if run_id else f"any run under {runs_root}"
    raise TraceNotFound(f"no trace of scenario {scenario_id!r} in {where} "
                        "(--runs names the folder of run folders, --run one run)")


def read_events(folder: Path) -> list[dict]:
    """The events of ``folder/trace.jsonl`` in order (an unreadable one becomes a note with
    its place among them)."""
    return [{"node": "unreadable", "line": number} if event is None else event
            for number, event in enumerate(read_json_lines(folder / TRACE_NAME), start=1)]


def checkpoint_count(folder: Path, thread_id: str) -> int | None:
    """How many LangGraph checkpoints the scenario's thread has (None: no checkpointer)."""
    path = folder / CHECKPOINTS_NAME
    if not path.is_file():
        return None
    with closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
        try:
            row = db.execute("SELECT COUNT(*) FROM checkpoints WHERE thread_id = ?",
                             (thread_id,)).fetchone()
        except sqlite3.DatabaseError:
            return None
    return int(row[0])


def status_of(folder: Path) -> dict:
    return read_json_object(folder / STATUS_NAME)


def format_trace(folder: Path, scenario_id: str, full: bool = False) -> str:
    """The trace as a person reads it: one block per node, long texts cut unless ``full``."""
    status = status_of(folder)
    lines = [f"trace of {scenario_id} in {folder}",
             f"status {status.get('status', '?')}, {status.get('attempts', 0)} attempts, "
             f"tokens {status.get('tokens_in', 0)} in / {status.get('tokens_out', 0)} out"]
    for event in read_events(folder):
        lines.append("")
        lines.extend(_format_event(event, full))
    count = checkpoint_count(folder, scenario_id)
    if count is not None:
        lines += ["", f"checkpoints: {count} in {folder / CHECKPOINTS_NAME} "
                      f"(thread_id {scenario_id})"]
    return "\n".join(lines)


def _format_event(event: dict, full: bool) -> list[str]:
    node = event.get("node", "?")
    attempt = f" #{event['attempt']}" if event.get("attempt") else (
        f" #{event['number']}" if event.get("number") else "")
    head = f"[{event.get('t_s', 0):8.2f} s] {node}{attempt}"
    if event.get("duration_s") is not None:
        head += f"  ({event['duration_s']:.2f} s)"
    body = _SUMMARIES.get(node, _generic)(event)
    out = [head, *(f"  {line}" for line in body)]
    for title, text in _texts(event):
        out.append(f"  {title}:")
        out.extend(f"    {line}" for line in _preview(text, full))
    return out


def _texts(event: dict) -> list[tuple[str, str]]:
    texts = []
    prompt = event.get("prompt")
    if isinstance(prompt, dict):
        texts.append(("prompt (system)", prompt.get("system", "")))
        texts.append(("prompt (user)", prompt.get("user", "")))
    for key, title in (("reply", "raw reply"), ("code", "extracted code"),
                       ("diff", "diff to the reference")):
        if event.get(key):
            texts.append((title, event[key]))
    error = event.get("error")
    if isinstance(error, dict) and error.get("traceback"):
        texts.append(("traceback", error["traceback"]))
    sandbox = event.get("sandbox") or {}
    if sandbox.get("stderr"):
        texts.append(("sandbox stderr", sandbox["stderr"]))
    return texts


def _preview(text: str, full: bool) -> list[str]:
    lines = str(text).splitlines() or [""]
    if full or len(lines) <= PREVIEW_LINES:
        return lines
    return [*lines[:PREVIEW_LINES], f"... {len(lines) - PREVIEW_LINES} more lines (--full)"]


def _generation(event: dict) -> list[str]:
    extraction = event.get("extraction") or {}
    lines = [f"strategy {event.get('strategy')}: {event.get('tokens_in', 0)} tokens in, "
             f"{event.get('tokens_out', 0)} out, LLM {event.get('llm_latency_s', 0):.2f} s; "
             f"code by {extraction.get('method', '-')}"]
    if extraction.get("warnings"):
        lines.append("warnings: " + "; ".join(extraction["warnings"]))
    if event.get("corrections"):
        lines.append("corrections: " + ", ".join(event["corrections"]))
    return lines + _error_line(event)


def _execution(event: dict) -> list[str]:
    sandbox = event.get("sandbox")
    lines = []
    if sandbox:
        lines.append(f"sandbox {sandbox.get('backend')}: exit {sandbox.get('exit_code')}, "
                     f"{sandbox.get('duration_s', 0):.2f} s"
                     + (", timed out" if sandbox.get("timed_out") else "")
                     + f", files {', '.join(sandbox.get('files') or []) or '-'}")
    else:
        lines.append("not run in the sandbox")
    return lines + _error_line(event)


def _validation(event: dict) -> list[str]:
    lines = ["valid" if event.get("valid") else "invalid"]
    if event.get("fixes_applied"):
        lines[0] += f" (auto-fixes: {', '.join(event['fixes_applied'])})"
    for err in event.get("errors") or []:
        where = f" line {err['line']}" if err.get("line") else ""
        lines.append(f"{err.get('code')}{where}: {err.get('message')}")
    return lines + _taxonomy_line(event)


def _fallback(event: dict) -> list[str]:
    lines = [f"reference {event.get('script')} run directly -> {event.get('status')}"]
    return lines + ([f"error: {event['error']}"] if event.get("error") else [])


def _generic(event: dict) -> list[str]:
    skip = {"node", "t_s", "duration_s", "prompt", "reply", "code", "diff", "traceback"}
    return [f"{k}: {v}" for k, v in event.items() if k not in skip]


def _error_line(event: dict) -> list[str]:
    error = event.get("error")
    if not error:
        return []
    message = error.get("message", "") if isinstance(error, dict) else str(error)
    kind = error.get("type", "Error") if isinstance(error, dict) else "error"
    return [f"error {kind}: {message}", *_taxonomy_line(event)]


def _taxonomy_line(event: dict) -> list[str]:
    return [f"taxonomy: {event['taxonomy']}"] if event.get("taxonomy") else []


_SUMMARIES = {"generate": _generation, "repair": _generation, "execute": _execution,
              "validate": _validation, "fallback": _fallback}

"""Every LLM call, logged locally in ``$SCENWEAVE_HOME/llm-calls.sqlite`` (like simonw/llm).

Set ``SCENWEAVE_LLM_LOG=0`` to switch it off (e.g. for a benchmark of the LLM alone).
"""

from __future__ import annotations

import json
import os
import sqlite3
from contextlib import closing
from datetime import UTC, datetime
from pathlib import Path

from scenweave.agent.home import home
from scenweave.agent.llm.messages import LLMReply, Prompt

LOG_NAME = "llm-calls.sqlite"
SCHEMA = """
CREATE TABLE IF NOT EXISTS calls (
    id INTEGER PRIMARY KEY,
    at TEXT NOT NULL,
    backend TEXT NOT NULL,
    model TEXT NOT NULL,
    scenario_id TEXT,
    purpose TEXT,
    system TEXT,
    prompt TEXT,
    reply TEXT,
    tokens_in INTEGER,
    tokens_out INTEGER,
    latency_s REAL,
    meta TEXT,
    run_id TEXT
)
"""
#: columns added after the first release, with their types (old logs gain them on open)
ADDED_COLUMNS = {"run_id": "TEXT"}


def log_path() -> Path:
    return home() / LOG_NAME


def log_call(prompt: Prompt, reply: LLMReply, run_id: str | None = None) -> None:
    """Append one call (of run ``run_id``) to the log (a no-op when ``SCENWEAVE_LLM_LOG=0``)."""
    if os.environ.get("SCENWEAVE_LLM_LOG", "1") == "0":
        return
    with closing(_connect()) as db, db:
        db.execute(
            "INSERT INTO calls (at, backend, model, scenario_id, purpose, system, prompt, reply,"
            " tokens_in, tokens_out, latency_s, meta, run_id) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?)",
            (datetime.now(UTC).isoformat(timespec="seconds"), reply.backend, reply.model,
             prompt.scenario_id, prompt.purpose, prompt.system, prompt.user, reply.text,
             reply.tokens_in, reply.tokens_out, reply.latency_s, json.dumps(reply.meta), run_id))


def recent_calls(limit: int = 20, scenario_id: str | None = None, run_id: str | None = None,
                 model: str | None = None) -> list[dict]:
    """The newest ``limit`` calls, newest first; only those of the scenario, run and model
    given."""
    wanted = {"scenario_id": scenario_id, "run_id": run_id, "model": model}
    tests = [(f"{column} = ?", value) for column, value in wanted.items() if value]
    where = "WHERE " + " AND ".join(t for t, _ in tests) if tests else ""
    with closing(_connect()) as db:
        db.row_factory = sqlite3.Row
        rows = db.execute(f"SELECT * FROM calls {where} ORDER BY id DESC LIMIT ?",
                          (*(v for _, v in tests), limit)).fetchall()
    return [dict(row) for row in rows]


def _connect() -> sqlite3.Connection:
    db = sqlite3.connect(log_path(), timeout=30)
    db.execute(SCHEMA)
    present = {row[1] for row in db.execute("PRAGMA table_info(calls)")}
    for column, kind in ADDED_COLUMNS.items():
        if column not in present:
            db.execute(f"ALTER TABLE calls ADD COLUMN {column} {kind}")
    return db

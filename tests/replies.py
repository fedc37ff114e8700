"""Recorded LLM replies that are right for a run's records: each scenario's worked example
with its record's values written in, as the agent must write it (whole-script strategy)."""

from __future__ import annotations

from pathlib import Path

from scenweave import corpus
from scenweave.corpus.worked_example import worked_example
from scenweave.inputs import InputSelection, load_input
from scenweave.runner import default_matcher, round_robin
from scenweave.spawn_db import SpawnDbError


def fenced(code: str) -> str:
    return f"Here is the script:\n```python\n{code}```\n"


def right_replies(records: Path, selection: InputSelection) -> dict[str, str]:
    """scenario id -> the right reply for it, placed as ``run_batch`` places it (records no
    spawn fits have none)."""
    loaded = load_input(records, selection)
    matcher = default_matcher()
    found = {}
    for index, params in round_robin(loaded.params):
        try:
            placed = matcher.assign(params, index)
        except SpawnDbError:
            continue
        found[params["scenario_id"]] = fenced(worked_example(corpus.retrieve(placed).script_path,
                                                             placed))
    return found

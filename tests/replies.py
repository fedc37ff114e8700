"""Recorded LLM replies that are right for a run's records: each scenario's worked example
with its record's values written in, as the agent must write it (whole-script strategy)."""

from __future__ import annotations

import json
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


def json_edits(before: str, after: str) -> str:
    """The JSON edit reply (``patch``) that turns worked example ``before`` into ``after``
    by changing values only: outside ``RECORD`` the scripts match line for line; inside it,
    each entry ``after`` holds with another value is edited, each it adds rides on the
    replace of the dict's last entry, and entries only ``before`` holds stay (unread)."""
    old, new = before.splitlines(), after.splitlines()
    (o1, o2), (n1, n2) = _record_block(old), _record_block(new)
    if len(old) - (o2 - o1) != len(new) - (n2 - n1):
        raise ValueError("the scripts differ outside RECORD")
    replaced = {i: b for i, b in zip([*range(o1), *range(o2, len(old))],
                                     [*new[:n1], *new[n2:]], strict=True) if old[i] != b}
    entries = {_key(line): i for i, line in enumerate(old[o1:o2], start=o1)}
    added = []
    for line in new[n1:n2]:
        if _key(line) in entries:
            if old[entries[_key(line)]] != line:
                replaced[entries[_key(line)]] = line
        else:
            added.append(line)
    if added:
        last = o2 - 1
        replaced[last] = "\n".join([replaced.get(last, old[last]), *added])
    return json.dumps({"edits": [{"search": old[i], "replace": text}
                                 for i, text in sorted(replaced.items())]})


def _record_block(lines: list[str]) -> tuple[int, int]:
    """The index range of RECORD's entries (between ``RECORD = {`` and its ``}``)."""
    start = lines.index("RECORD = {") + 1
    return start, lines.index("}", start)


def _key(entry: str) -> str:
    return entry.split(":", 1)[0].strip()

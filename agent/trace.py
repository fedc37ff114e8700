"""A scenario folder's readable event log (``trace.jsonl``; the folder's file names are
``schemas.scenario_folder``'s).

Both the agent and the deterministic ``--no-llm`` path write it, so it lives here, below
the application shell. Importing this module loads nothing of LangGraph.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any


class Trace:
    """A readable event log, one JSON object per line (``trace.jsonl``)."""

    def __init__(self, path: Path):
        self.path = path
        self.started = time.perf_counter()

    def event(self, node: str, **fields: Any) -> None:
        entry = {"node": node, "t_s": round(time.perf_counter() - self.started, 4), **fields}
        with open(self.path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(entry, default=str) + "\n")

"""A scenario folder's readable event log, and the names of the files written into the folder.

Both the agent and the deterministic ``--no-llm`` path write these, so they live here, below
the application shell. Importing this module loads nothing of LangGraph.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

XOSC_NAME = "scenario.xosc"
CODE_NAME = "scenario.py"
PARAMS_NAME = "params.json"
TRACE_NAME = "trace.jsonl"
CHECKPOINTS_NAME = "checkpoints.sqlite"


class Trace:
    """A readable event log, one JSON object per line (``trace.jsonl``)."""

    def __init__(self, path: Path):
        self.path = path
        self.started = time.perf_counter()

    def event(self, node: str, **fields: Any) -> None:
        entry = {"node": node, "t_s": round(time.perf_counter() - self.started, 4), **fields}
        with open(self.path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(entry, default=str) + "\n")

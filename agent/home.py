"""The one home folder for ScenWeave's local state (LLM call log, caches): ``SCENWEAVE_HOME``."""

from __future__ import annotations

import os
from pathlib import Path


def home() -> Path:
    """Return ``$SCENWEAVE_HOME`` (default ``~/.scenweave``), creating it if needed."""
    path = Path(os.environ.get("SCENWEAVE_HOME") or Path.home() / ".scenweave")
    path.mkdir(parents=True, exist_ok=True)
    return path

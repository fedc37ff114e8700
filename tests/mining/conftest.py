"""Where the mining tests find their data: the fixtures beside them, and the team's real
NGSIM snippets (``../shared/data`` beside the repository, or ``$SCENWEAVE_SHARED_DATA``),
which tests skip without."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parent / "data"
REPO = Path(__file__).resolve().parents[2]


def shared_data() -> Path | None:
    """The shared data folder, if this machine has it."""
    configured = os.environ.get("SCENWEAVE_SHARED_DATA")
    folder = Path(configured) if configured else REPO.parent / "shared" / "data"
    return folder if folder.is_dir() else None


@pytest.fixture(scope="session")
def ngsim_snippets() -> Path:
    """The shared NGSIM CommonRoad snippets; skips where they are not on this machine."""
    folder = shared_data()
    if folder is None or not (folder / "ngsim").is_dir():
        pytest.skip("no shared NGSIM data here (../shared/data or $SCENWEAVE_SHARED_DATA)")
    return folder / "ngsim"


@pytest.fixture(scope="session")
def data() -> Path:
    """The fixtures written by make_fixtures.py."""
    return DATA

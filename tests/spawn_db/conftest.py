"""Fixtures of the spawn_db tests: the bundled Town04 network (``tests.roads``) and database,
loaded once."""

from __future__ import annotations

import pytest

from scenweave.spawn_db import DEFAULT_DB_PATH, load_database
from tests.roads.conftest import town04  # noqa: F401 - the road model's fixture, shared


@pytest.fixture(scope="session")
def town04_db() -> dict:
    """The committed Town04 spawn database."""
    return load_database(DEFAULT_DB_PATH)

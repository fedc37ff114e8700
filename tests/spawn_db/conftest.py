"""Fixtures of the spawn_db tests: the bundled Town04 network and database, loaded once."""

from __future__ import annotations

import pytest

from scenweave.spawn_db import DEFAULT_DB_PATH, load_database, road_network
from scenweave.spawn_db.road_network import RoadNetwork


@pytest.fixture(scope="session")
def town04() -> RoadNetwork:
    """The lane graph of the bundled Town04 map."""
    return road_network()


@pytest.fixture(scope="session")
def town04_db() -> dict:
    """The committed Town04 spawn database."""
    return load_database(DEFAULT_DB_PATH)

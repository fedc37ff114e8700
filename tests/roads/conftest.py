"""Fixtures of the road model's tests: the bundled Town04 lane graph, loaded once."""

from __future__ import annotations

import pytest

from scenweave.roads import RoadNetwork, road_network


@pytest.fixture(scope="session")
def town04() -> RoadNetwork:
    """The lane graph of the bundled Town04 map."""
    return road_network()

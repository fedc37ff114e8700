"""Fixtures shared across test areas: small sample data made once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenweave.ingest.samples import write_highway_samples, write_urban_samples

SAMPLE_SEED = 7


@pytest.fixture(scope="session")
def esmini() -> None:
    """Skip, loudly, where no esmini is installed (setup installs it: scripts/setup.d)."""
    from scenweave.player import PlayerUnavailable, find_esmini

    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(f"REPLAY NOT TESTED: no esmini here ({err})")


@pytest.fixture(scope="session")
def sample_raw(tmp_path_factory) -> Path:
    """Raw sample data in the MOOVE formats: 3 rows per highway class, 2 files per urban class."""
    root = tmp_path_factory.mktemp("sample_raw")
    write_highway_samples(root / "highway", seed=SAMPLE_SEED, per_class=3)
    write_urban_samples(root / "urban", seed=SAMPLE_SEED, per_class=2)
    return root

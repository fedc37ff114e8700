"""What the player tests share: a skip, named by its reason, where esmini is not installed."""

from __future__ import annotations

import pytest

from scenweave.player import PlayerUnavailable, find_esmini


@pytest.fixture
def needs_esmini() -> None:
    """Skip the test, saying why, when no esmini is found (``pytest.mark.usefixtures``)."""
    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(str(err))

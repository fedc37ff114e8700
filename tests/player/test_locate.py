"""Where ``player.find_esmini`` looks: ESMINI_HOME, the workplace copy, setup's install."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenweave.player import PlayerUnavailable, find_esmini, locate, player_status

REAL_LIBRARY = locate.WORKPLACE_HOME / "bin" / locate.LIBRARY


def make_home(folder: Path) -> Path:
    """An esmini home whose bin/libesminiLib.so is the workplace's library (or a stand-in)."""
    (folder / "bin").mkdir(parents=True)
    library = folder / "bin" / locate.LIBRARY
    if REAL_LIBRARY.is_file():
        library.symlink_to(REAL_LIBRARY)
    else:
        library.write_bytes(b"not a library")
    return folder


@pytest.fixture
def places(tmp_path, monkeypatch):
    """The workplace and installed homes moved to (empty) temporary folders."""
    monkeypatch.delenv("ESMINI_HOME", raising=False)
    monkeypatch.delenv("SCENWEAVE_ESMINI_PREFIX", raising=False)
    monkeypatch.setattr(locate, "WORKPLACE_HOME", tmp_path / "workplace")
    monkeypatch.setattr(locate, "INSTALLED_HOME", tmp_path / "installed")
    return tmp_path


def test_esmini_home_wins_over_the_other_places(places, monkeypatch):
    home = make_home(places / "mine")
    make_home(places / "workplace")
    make_home(places / "installed")
    monkeypatch.setenv("ESMINI_HOME", str(home))
    install = find_esmini()
    assert (install.source, install.home) == ("ESMINI_HOME", home)
    assert install.library == home / "bin" / "libesminiLib.so"


def test_a_bogus_esmini_home_falls_through_to_the_workplace_copy(places, monkeypatch):
    monkeypatch.setenv("ESMINI_HOME", str(places / "nothing-here"))
    workplace = make_home(places / "workplace")
    make_home(places / "installed")
    install = find_esmini()
    assert install.home == workplace
    assert install.source.startswith("workplace")


def test_setup_install_comes_last_and_follows_the_prefix_variable(places, monkeypatch):
    make_home(places / "installed")
    assert find_esmini().home == places / "installed"
    moved = make_home(places / "elsewhere")
    monkeypatch.setenv("SCENWEAVE_ESMINI_PREFIX", str(moved))
    install = find_esmini()
    assert install.home == moved
    assert str(moved) in install.source


def test_missing_everywhere_names_esmini_home_and_every_place_tried(places, monkeypatch):
    monkeypatch.setenv("ESMINI_HOME", str(places / "bogus"))
    with pytest.raises(PlayerUnavailable) as caught:
        find_esmini()
    message = str(caught.value)
    assert "ESMINI_HOME" in message
    for folder in ("bogus", "workplace", "installed"):
        assert str(places / folder / "bin" / "libesminiLib.so") in message
    status = player_status()
    assert status["available"] is False
    assert "set ESMINI_HOME" in status["problem"]


def test_unset_esmini_home_is_said_when_nothing_is_found(places):
    with pytest.raises(PlayerUnavailable, match="ESMINI_HOME: unset"):
        find_esmini()


@pytest.mark.skipif(not REAL_LIBRARY.is_file(), reason="no workplace esmini (../shared/esmini)")
def test_the_workplace_library_reports_its_version(monkeypatch):
    monkeypatch.delenv("ESMINI_HOME", raising=False)
    install = find_esmini()
    assert install.version.startswith("v3.6.0")
    assert player_status() == {"available": True, **install.to_dict()}


def test_a_file_that_is_no_library_has_an_unknown_version(tmp_path):
    fake = tmp_path / "libesminiLib.so"
    fake.write_bytes(b"not a library")
    assert locate.library_version(fake) == "unknown"

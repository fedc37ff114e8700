"""``scenweave doctor --need``: every optional part named with what provides it, and a
non-zero exit when a part the user needs is missing (issue 35)."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from scenweave import doctor, sandbox
from scenweave.cli import cli


@pytest.fixture
def no_player(tmp_path, monkeypatch):
    empty = tmp_path / "empty"
    empty.mkdir()
    for setting in ("ESMINI_HOME", "SCENWEAVE_WORKPLACE_ESMINI", "SCENWEAVE_ESMINI_PREFIX"):
        monkeypatch.setenv(setting, str(empty))


@pytest.fixture
def quick(monkeypatch):
    """No Ollama to wait for; the sandbox as a machine with bwrap only."""
    monkeypatch.setenv("OLLAMA_HOST", "http://127.0.0.1:9")
    monkeypatch.setattr(sandbox, "check_backends",
                        lambda settings=None: {"docker": "no engine answers", "bwrap": None})


def doctor_cli(*args: str):
    return CliRunner().invoke(cli, ["doctor", *args])


def test_a_missing_needed_player_exits_1_and_says_how_to_get_it(no_player, quick):
    result = doctor_cli("--need", "player,bwrap")
    assert result.exit_code == 1, result.output
    player = next(line for line in result.output.splitlines() if line.startswith("player:"))
    assert player.startswith("player: MISSING - esmini not found")
    assert f"-> {doctor.PROVIDED_BY['player']}" in player
    assert "doctor: needed but missing: player" in result.stderr


def test_needs_that_are_there_exit_0(quick):
    assert doctor_cli("--need", "bwrap,sandbox").exit_code == 0


def test_a_missing_backend_is_named_with_its_provider(quick):
    result = doctor_cli("--need", "docker")
    assert result.exit_code == 1
    sandbox_line = next(line for line in result.output.splitlines()
                        if line.startswith("sandbox:"))
    assert f"docker unavailable: no engine answers -> {doctor.SANDBOX_PROVIDED_BY['docker']}" \
        in sandbox_line


def test_without_need_it_stays_a_report(no_player, quick):
    assert doctor_cli().exit_code == 0


def test_an_unknown_part_is_a_usage_error(quick):
    result = doctor_cli("--need", "player,espresso")
    assert result.exit_code == 2
    assert "unknown part espresso" in result.output


def test_json_names_what_provides_every_part(no_player, quick):
    result = doctor_cli("--json", "--need", "queue,esmini")
    report = json.loads(result.output)
    for name in doctor.CHECKS:
        assert report[name]["provided_by"], name
    for backend, info in report["sandbox"]["backends"].items():
        assert info["provided_by"] == doctor.SANDBOX_PROVIDED_BY[backend]
    assert report["needs"]["asked"] == ["queue", "esmini"]
    assert "esmini" in report["needs"]["missing"]
    assert result.exit_code == 1

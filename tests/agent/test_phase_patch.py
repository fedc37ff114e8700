"""The agent keeps up with speed profiles (issue 22, item 6): for a record that needs two
phases, the prompt lists its phases, the right patch of the worked example decodes under the
value-only grammar (llama.cpp's own sampler over SmolLM2's vocabulary) and, applied, plays
back the record in esmini; a patch that flattens the phases fails the replay."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from lxml import etree

from scenweave import corpus, roads
from scenweave.agent.edits import apply_edits
from scenweave.agent.prompts import patch_prompt
from scenweave.corpus.worked_example import adaptation, provenance, worked_example
from scenweave.ingest.samples import write_highway_samples
from scenweave.inputs import InputSelection, load_input
from scenweave.judge import validate_xosc
from scenweave.judge.replay import judge_replay
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.player import ReplaySettings, replay_file
from scenweave.runner import default_matcher
from tests.agent.test_value_grammar import GrammarSampler
from tests.replies import json_edits


@pytest.fixture(scope="module")
def phased(tmp_path_factory) -> dict:
    """A car-following sample record whose lead needs two phases, placed as a run does."""
    raw = tmp_path_factory.mktemp("phased")
    write_highway_samples(raw / "highway", 7, 1, phased=1)
    records = [p for p in load_input(raw, InputSelection(classes=("FLF",))).params
               if p.get("npc_phases")]
    assert records, "the phased sample row needs phases"
    return default_matcher().assign(records[0], 0)


def _patched(params: dict) -> tuple[str, str, str]:
    """(the worked example shown, the right reply, its grammar)."""
    script = corpus.retrieve(params).script_path
    shown, values = adaptation(script, params)
    assert "npc_phases" in values  # the record's values the prompt lists include its phases
    right = json_edits(shown, worked_example(script, params))
    grammar = patch_prompt(params, shown, values=values).reply_grammar
    return shown, right, grammar


def _run(code: str, params: dict, out: Path) -> Path:
    """The adapted script as the sandbox runs it: given only the provenance keys."""
    namespace: dict = {}
    exec(compile(code, "adapted.py", "exec"), namespace)  # noqa: S102 - our own test script
    return Path(namespace["generate"](provenance(params), str(out)))


def test_the_prompt_lists_the_phases_to_write_in(phased):
    script = corpus.retrieve(phased).script_path
    shown, values = adaptation(script, phased)
    prompt = patch_prompt(phased, shown, values=values)
    assert "npc_phases" in prompt.user and "'target_ms'" in prompt.user


def test_the_right_patch_for_a_phased_record_decodes_under_the_grammar(phased):
    _, right, grammar = _patched(phased)
    assert any('"npc_phases": [{' in e["replace"] for e in json.loads(right)["edits"])
    assert GrammarSampler().accepts(grammar, right)


@pytest.mark.usefixtures("esmini")
def test_the_right_patch_plays_back_and_a_flattened_one_does_not(tmp_path, phased):
    shown, right, _ = _patched(phased)
    code, _ = apply_edits(shown, right)
    played = validate_xosc(_run(code, phased, tmp_path / "right.xosc"), phased,
                           replay=ReplaySettings())
    assert played.valid, [f"{f.code}: {f.message}" for f in played.errors]
    edits = json.loads(right)["edits"]
    flat = [dict(e, replace="\n".join(line for line in e["replace"].split("\n")
                                      if '"npc_phases"' not in line)) for e in edits]
    code, _ = apply_edits(shown, json.dumps({"edits": flat}))
    assert '"npc_phases"' not in code
    flat_path = _run(code, phased, tmp_path / "flat.xosc")
    flattened = validate_xosc(flat_path, phased, replay=ReplaySettings())
    assert not flattened.valid  # the phases it dropped are missing (FIDELITY_MISSING) ...
    playback = replay_file(flat_path, roads.DEFAULT_MAP_PATH, ReplaySettings())
    findings = judge_replay(playback, phased, ScenarioDoc(etree.parse(str(flat_path))))
    assert "REPLAY_GAP" in {f.code for f in findings}  # ... and played, the end gap is off

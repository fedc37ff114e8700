"""Tests that fail on what the model does (issue 15): a reply that keeps every value of the
record ends ok on the first attempt; a wrong speed, a swapped lane-change direction, an
invented API or a script that reads params it was not given never ends ok."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenweave.agent import run_scenario
from tests.agent.conftest import adapted_source, fenced, reference_source
from tests.corpus.params_examples import example_params


def wrong_speed(code: str) -> str:
    params = example_params(code)
    right = f'"ego_speed_ms": {params["ego_speed_ms"]!r},'
    return _changed(adapted_source(code), right,
                    f'"ego_speed_ms": {params["ego_speed_ms"] + 3.0!r},')


def swapped_direction(code: str) -> str:
    side = example_params(code)["lane_change_direction"]
    other = {"left": "right", "right": "left"}[side]
    return _changed(adapted_source(code), f'"lane_change_direction": "{side}",',
                    f'"lane_change_direction": "{other}",')


def invented_api(code: str) -> str:
    return _changed(adapted_source(code), "    highway_npc,\n",
                    "    highway_npc,\n    highway_lead_vehicle,\n")


def reads_params(code: str) -> str:
    return reference_source(code)  # the parametric script: every value read from params


def _changed(code: str, old: str, new: str) -> str:
    assert code.count(old) == 1, old
    return code.replace(old, new)


BAD = {"wrong_speed": ("BRAKE", wrong_speed, {"fidelity", "validation", "replay"}),
       "swapped_direction": ("LCF", swapped_direction, {"fidelity", "validation", "replay"}),
       "invented_api": ("BRAKE", invented_api, {"import", "api_hallucination"}),
       "reads_params": ("BRAKE", reads_params, {"runtime", "name"})}


def run(code: str, settings, tmp_path: Path):
    out = tmp_path / "scenario"
    out.mkdir(exist_ok=True)
    return run_scenario(example_params(code), out, settings), out


@pytest.mark.parametrize("code", ["BRAKE", "LCF", "U4_4"])
def test_the_record_s_values_written_in_end_ok_on_attempt_one(code, replay, tmp_path):
    outcome, out = run(code, replay([fenced(adapted_source(code))]), tmp_path)
    assert (outcome.status, outcome.attempts, outcome.fallback) == ("ok", 1, False)
    assert (out / "scenario.py").read_text() == adapted_source(code)


@pytest.mark.parametrize("kind", sorted(BAD))
def test_a_wrong_reply_is_repaired_never_ok(kind, replay, tmp_path):
    code, make, taxonomy = BAD[kind]
    bad = make(code)
    outcome, out = run(code, replay([fenced(bad), fenced(adapted_source(code))]), tmp_path)
    assert (outcome.status, outcome.attempts) == ("repaired", 2)
    assert set(outcome.error_taxonomy) <= taxonomy, outcome.error_taxonomy
    trace = [json.loads(line) for line in (out / "trace.jsonl").read_text().splitlines()]
    failed = next(e for e in trace if e["node"] in ("execute", "validate") and e.get("taxonomy"))
    assert failed["attempt"] == 1


@pytest.mark.parametrize("kind", ["wrong_speed", "reads_params"])
def test_a_model_that_keeps_it_wrong_ends_in_the_fallback(kind, replay, tmp_path):
    code, make, taxonomy = BAD[kind]
    outcome, out = run(code, replay([fenced(make(code))] * 3), tmp_path)
    assert (outcome.status, outcome.attempts, outcome.fallback) == ("fallback", 3, True)
    assert set(outcome.error_taxonomy) <= taxonomy
    assert (out / "scenario.py").read_text() == reference_source(code)

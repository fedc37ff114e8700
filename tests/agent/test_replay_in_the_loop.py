"""The replay inside the agent: a valid file that does not play back as recorded is a failed
attempt the LLM is told about, and a fallback that fails the replay ends ``failed``."""

from __future__ import annotations

import json

import pytest

from scenweave.agent import run_scenario
from scenweave.inputs import InputSelection, load_input
from scenweave.player import ReplaySettings
from scenweave.spawn_db import SpawnMatcher
from tests.agent.conftest import adapted_source, fenced
from tests.agent.test_graph import events, nodes_in_trace

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("esmini")]

#: a script that writes the reference's file, then gives every trigger a rising edge: valid,
#: faithful to every number, and in esmini nothing scripted at t = 0 ever happens
RISING_EDGES = '''

_reference_generate = generate


def generate(params: dict, out_path: str) -> Path:
    path = _reference_generate(params, out_path)
    text = Path(out_path).read_text()
    Path(out_path).write_text(text.replace('conditionEdge="none"', 'conditionEdge="rising"'))
    return path
'''


@pytest.fixture(scope="module")
def stop_at_red_record(sample_raw) -> dict:
    """A U4_1 sample record's params, before the spawn stage."""
    return load_input(sample_raw, InputSelection(classes=("U4_1",), per_class=1)).params[0]


@pytest.fixture
def stop_at_red(stop_at_red_record) -> dict:
    """The U4_1 record with its spawn on Town04 (the replay needs real map positions)."""
    return SpawnMatcher().assign(stop_at_red_record, 0)


def _run(params: dict, settings, tmp_path):
    out = tmp_path / "scenario"
    out.mkdir()
    return run_scenario(json.loads(json.dumps(params)), out, settings), out


def test_a_replay_failure_is_repaired_with_what_the_engine_showed(replay, stop_at_red,
                                                                  tmp_path):
    right = adapted_source("U4_1", stop_at_red)  # the record's values written in
    settings = replay([fenced(right + RISING_EDGES), fenced(right)], replay=ReplaySettings())
    outcome, out = _run(stop_at_red, settings, tmp_path)
    assert outcome.status == "repaired"
    assert outcome.error_taxonomy == ["replay"]
    first = events(out, "validate")[0]
    assert not first["valid"]
    assert {e["code"] for e in first["errors"]} >= {"REPLAY_EVENT", "REPLAY_NO_STOP"}
    prompt = events(out, "repair")[0]["prompt"]["user"]
    assert "esmini" in prompt and "REPLAY_NO_STOP" in prompt and "the record" in prompt
    assert outcome.replay == {**outcome.replay, "played": True, "passed": True}
    assert (out / "replay.json").is_file()
    assert nodes_in_trace(out)[-1] == "validate"


def test_a_fallback_that_fails_the_replay_ends_failed_with_taxonomy_replay(
        replay, stop_at_red_record, tmp_path, monkeypatch):
    from scenweave.scenario_lib import builder

    # the fallback (the reference, run in this process) with a slow lead that never gets out
    # of the way: valid and faithful, and the ego runs into it when played
    monkeypatch.setattr(builder, "lead_stays_ahead", lambda *args: None)
    params = SpawnMatcher().assign({
        **stop_at_red_record, "maneuver_class": "U1_1", "maneuver_tag": "in_lane_driving",
        "lead_present": True, "lead_distance_m": 15.0, "lead_speed_ms": 1.0,
        "lead_vehicle_type": "car"}, 0)
    failing = "def generate(params, out_path):\n    raise ValueError('no scenario')\n"
    settings = replay([fenced(failing)], max_attempts=1, replay=ReplaySettings())
    outcome, out = _run(params, settings, tmp_path)
    assert outcome.status == "failed" and outcome.fallback
    assert outcome.error_taxonomy == ["runtime", "replay"]
    assert "REPLAY_COLLISION" in outcome.error
    assert outcome.replay["codes"] == ["REPLAY_COLLISION"]

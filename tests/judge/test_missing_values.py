"""The judge reads what may be missing as "not checked", never as a crash: a params value the
replay needs (``schemas.params.number`` gives None), a name the file does not give."""

from __future__ import annotations

from pathlib import Path

import pytest
from lxml import etree

from scenweave import corpus, roads
from scenweave.inputs import InputSelection, load_input
from scenweave.judge.replay import judge_replay
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.judge.variation import compare
from scenweave.player import replay_file
from scenweave.spawn_db import SpawnMatcher


def _codes(path: Path, params: dict) -> set[str]:
    playback = replay_file(path, roads.DEFAULT_MAP_PATH, None)
    return {f.code for f in judge_replay(playback, params, ScenarioDoc(etree.parse(str(path))))}


@pytest.mark.slow
@pytest.mark.usefixtures("esmini")
def test_a_stop_at_red_without_the_ego_start_speed_is_judged(tmp_path, sample_raw):
    """The light check of a stop at red asks whether the ego brakes on green, which needs the
    recorded start speed; without it that one question is skipped (it raised TypeError)."""
    loaded = load_input(sample_raw, InputSelection(per_class=1))
    record = next(p for p in loaded.params if p["maneuver_class"] == "U4_1")
    params = SpawnMatcher().assign(record, 0)
    path = corpus.generate(params, tmp_path / "U4_1.xosc")
    del params["ego_speed_ms"]
    assert _codes(path, params) == set()
    tree = etree.parse(str(path))
    for light in tree.getroot().iter("TrafficSignalStateAction"):
        light.set("state", "green")  # the ego now stops at green: still found
    tree.write(str(path), xml_declaration=True, encoding="utf-8")
    assert "REPLAY_LIGHT" in _codes(path, params)


def _scenario(path: Path, *objects: str) -> Path:
    entities = "".join(f"<ScenarioObject{o}><Vehicle name='vehicle.a'/></ScenarioObject>"
                       for o in objects)
    path.write_text(f"<OpenSCENARIO><Entities>{entities}</Entities></OpenSCENARIO>",
                    encoding="utf-8")
    return path


def test_a_variant_dropping_an_unnamed_actor_is_a_violation(tmp_path):
    """An actor without a name (the XSD requires one) is still an actor of the record: a
    variant without it drops it (the list of names held None, and naming it raised)."""
    faithful = _scenario(tmp_path / "faithful.xosc", " name='hero'", "")
    variant = _scenario(tmp_path / "variant.xosc", " name='hero'")
    found = compare(faithful, variant)
    assert [f.code for f in found.violations] == ["VARY_ACTOR_MISSING"]

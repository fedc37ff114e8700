"""The map cut (``player.maps``): a replay on the cut copy records what the whole map gives.

Sample scenarios are made the way a run makes them (first sample record of a class, its spawn
assigned, the reference script): a highway lane change, a highway cut-in behind (two cars, a
lane change) and the urban right turn (``AcquirePositionAction`` route, a traffic light).
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest
from lxml import etree

from scenweave import corpus, roads
from scenweave.inputs import InputSelection, load_input
from scenweave.player import Playback, ReplaySettings, find_esmini, maps, replay_file
from scenweave.player.errors import PlayerUnavailable
from scenweave.player.replay import _lights_of
from scenweave.player.translate import translate
from scenweave.roads import road_graph
from scenweave.spawn_db import SpawnMatcher

MAP = roads.DEFAULT_MAP_PATH
CLASSES = ("LCF", "CINB", "U4_4")


def _esmini_or_skip() -> None:
    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(str(err))


@pytest.fixture(scope="module")
def scenarios(sample_raw, tmp_path_factory) -> dict[str, Path]:
    """One scenario file per class in ``CLASSES``, spawned on Town04 as a run does."""
    loaded = load_input(sample_raw, InputSelection(classes=CLASSES, per_class=1))
    matcher = SpawnMatcher()
    folder = tmp_path_factory.mktemp("map_cut")
    found = {}
    for params in loaded.params:
        params = matcher.assign(params, 0)
        code = params["maneuver_class"]
        found[code] = corpus.generate(json.loads(json.dumps(params)), folder / f"{code}.xosc")
    assert set(found) == set(CLASSES)
    return found


def _plan(path: Path, duration_s: float | None = None) -> tuple[etree._Element, maps.MapCut]:
    translated = translate(path.read_bytes(), Path("map.xodr"), _lights_of(MAP))
    scenario = etree.fromstring(translated.xml)
    stop = max(float(c.get("value")) for c in
               scenario.iterfind("Storyboard/StopTrigger//SimulationTimeCondition"))
    cut = maps.plan_cut(scenario, MAP, stop + 0.05 if duration_s is None else duration_s,
                        translated.light_signals.values())
    return scenario, cut


def assert_same_playback(cut: Playback, whole: Playback) -> None:
    """Same samples, positions within 1e-6, same collisions, storyboard, lights and end."""
    assert cut.engine_error is None and whole.engine_error is None, (cut.engine_error,
                                                                      whole.engine_error)
    assert cut.times == whole.times
    assert cut.tracks.keys() == whole.tracks.keys()
    for name, track in whole.tracks.items():
        for key, values in track.items():
            other = cut.tracks[name][key]
            assert len(other) == len(values), (name, key)
            worst = max((abs(a - b) for a, b in zip(other, values, strict=True)), default=0.0)
            assert worst <= 1e-6, f"{name}.{key} differs by {worst}"
    assert cut.boxes == whole.boxes
    assert cut.collisions == whole.collisions
    assert cut.storyboard == whole.storyboard
    assert cut.lights == whole.lights
    assert cut.quit_by_engine == whole.quit_by_engine


@pytest.mark.parametrize("code", CLASSES)
def test_a_cut_map_replay_records_what_the_whole_map_gives(scenarios, code):
    _esmini_or_skip()
    cut = replay_file(scenarios[code], MAP, ReplaySettings())
    whole = replay_file(scenarios[code], MAP, ReplaySettings(cut_map=False))
    assert cut.timings_s["replays"] == 1, "the cut replay was played again on the whole map"
    assert cut.timings_s["map_share"] < 0.6, cut.timings_s
    assert whole.timings_s["replays"] == 1 and "map_share" not in whole.timings_s
    assert_same_playback(cut, whole)
    assert len(whole.storyboard) > 5
    if code == "U4_4":  # the route through the junction and the light were played
        assert any(j >= 0 for j in whole.tracks["hero"]["junction"])
        assert whole.lights and set(whole.lights.values()) <= {"green", "yellow", "red"}
    elif code == "LCF":  # the lane change was played
        assert len(set(whole.tracks["hero"]["lane"])) > 1
    else:
        assert len(whole.tracks) == 2


def test_the_cut_copy_loads_cleanly_and_keeps_the_light(scenarios):
    scenario, cut = _plan(scenarios["U4_4"])
    assert not cut.whole, cut.reason
    root = etree.parse(str(maps.cut_map(MAP, cut.roads))).getroot()
    roads = {r.get("id") for r in root.iterfind("road")}
    junctions = {j.get("id") for j in root.iterfind("junction")}
    assert roads == set(cut.roads) and cut.core <= roads
    assert cut.kept_m < 0.6 * cut.map_m and len(roads) < len(road_graph(MAP).roads)
    for road in root.iterfind("road"):
        for link in road.iterfind("link/*"):
            kind = link.get("elementType")
            assert link.get("elementId") in (junctions if kind == "junction" else roads)
        assert road.get("junction") in junctions | {"-1"}
    for connection in root.iterfind("junction/connection"):
        assert connection.get("incomingRoad") in roads
        assert connection.get("connectingRoad") in roads
    names = [a.get("name") for a in scenario.iter("TrafficSignalStateAction")]
    assert names
    signals = {s.get("id") for s in root.iter("signal") if s.get("dynamic") == "yes"}
    assert set(names) <= signals
    assert all(s.get("value") is None for s in root.iter("signal") if s.get("dynamic") == "yes")


def test_a_replay_that_leaves_the_cut_is_played_again_on_the_whole_map(scenarios, monkeypatch):
    """With no reach at all the cars drive off the cut roads: the safety net must notice
    (else the trajectories below differ) and play the scenario on the whole map."""
    _esmini_or_skip()
    monkeypatch.setattr(maps, "REACH_SLACK", 0.0)
    monkeypatch.setattr(maps, "REACH_MARGIN_M", 0.0)
    monkeypatch.setattr(maps, "ROUTE_SLACK", 0.0)
    monkeypatch.setattr(maps, "ROUTE_MARGIN_M", 0.0)
    scenario, cut = _plan(scenarios["LCF"])
    assert not cut.whole and len(cut.core) <= 3
    first, _ = _played(scenario, cut)
    assert not cut.covers(first.tracks)
    played = replay_file(scenarios["LCF"], MAP, ReplaySettings())
    assert played.timings_s["replays"] == 2 and played.timings_s["map_share"] == 1.0
    assert_same_playback(played, replay_file(scenarios["LCF"], MAP,
                                             ReplaySettings(cut_map=False)))


def _played(scenario: etree._Element, cut: maps.MapCut) -> tuple[Playback, float]:
    from scenweave.player.replay import _play

    stop = max(float(c.get("value")) for c in
               scenario.iterfind("Storyboard/StopTrigger//SimulationTimeCondition"))
    return _play(scenario, MAP, cut, stop, ReplaySettings())


def test_covers_accepts_the_core_and_rejects_leaving_it_or_driving_into_a_guarded_end():
    cut = maps.MapCut(frozenset({"1", "2", "3"}), core=frozenset({"1", "2"}),
                      guarded={("1", 1): frozenset(), ("2", 0): frozenset({1})},
                      lengths={"1": 100.0, "2": 50.0})

    def track(*steps):
        return {"car": {"road": [r for r, _, _ in steps], "lane": [lane for _, lane, _ in steps],
                        "s": [s for _, _, s in steps]}}

    assert cut.covers(track((1, -1, 10.0), (1, -1, 50.0), (1, -1, 98.0)))
    assert not cut.covers(track((1, -1, 98.0), (1, -1, 99.5)))  # up to a dead end
    assert cut.covers(track((1, -1, 99.5), (1, -1, 98.0)))  # driving away from it
    assert not cut.covers(track((1, -1, 10.0), (3, -1, 1.0)))  # kept but not expected
    assert not cut.covers(track((2, -1, 5.0), (2, -1, 0.5)))  # a lane without connections
    assert cut.covers(track((2, 1, 5.0), (2, 1, 0.5)))  # the lane with its own connections
    assert maps.MapCut(None).covers(track((7, -1, 0.0)))


@pytest.mark.parametrize("edit, reason", [
    (lambda root: root.find(".//AbsoluteTargetSpeed").set("value", "$speed"), "not a number"),
    (lambda root: _replace_position(root, "<RelativeWorldPosition entityRef='hero' dx='5' "
                                          "dy='0'/>"), "RelativeWorldPosition"),
    (lambda root: root.find(".//PrivateAction").append(etree.fromstring(
        "<RoutingAction><FollowTrajectoryAction/></RoutingAction>")), "FollowTrajectoryAction"),
    (lambda root: _replace_position(root, "<LanePosition roadId='99999' laneId='-1' s='1'/>"),
     "roadId='99999'"),
    (lambda root: root.find(".//SimulationTimeCondition").getparent().append(etree.fromstring(
        "<RelativeDistanceCondition entityRef='hero' value='5' freespace='false' "
        "relativeDistanceType='longitudinal' rule='lessThan' coordinateSystem='road'/>")),
     "measures along the roads"),
])
def test_what_the_reach_cannot_bound_plays_on_the_whole_map(scenarios, tmp_path, edit, reason):
    root = etree.parse(str(scenarios["LCF"])).getroot()
    edit(root)
    path = tmp_path / "edited.xosc"
    path.write_bytes(etree.tostring(root))
    _, cut = _plan(path)
    assert cut.whole and reason in cut.reason, cut.reason
    _, cut = _plan(scenarios["LCF"], duration_s=math.inf)
    assert cut.whole


def _replace_position(root: etree._Element, xml: str) -> None:
    position = root.find(".//TeleportAction/Position")
    for child in list(position):
        position.remove(child)
    position.append(etree.fromstring(xml))


def test_cut_copies_are_cached_per_map_file_and_road_set(scenarios, tmp_path):
    _, cut = _plan(scenarios["CINB"])
    assert not cut.whole
    first = maps.cut_map(MAP, cut.roads)
    assert maps.cut_map(MAP, frozenset(cut.roads)) == first
    fewer = frozenset(sorted(cut.roads)[1:])
    assert maps.cut_map(MAP, fewer) != first
    other_file = tmp_path / "Town04.xodr"
    shutil.copy(MAP, other_file)
    assert maps.cut_map(other_file, cut.roads) != first
    assert maps.cut_map(other_file, cut.roads).read_bytes() == first.read_bytes()
    assert maps.cut_map(MAP, None) == maps.esmini_map(MAP)


def test_the_whole_map_copy_equals_the_map_but_for_light_values():
    whole = etree.parse(str(maps.esmini_map(MAP))).getroot()
    original = etree.parse(str(MAP)).getroot()
    for signal in original.iter("signal"):
        if signal.get("dynamic") == "yes":
            signal.attrib.pop("value", None)
    assert etree.tostring(whole, method="c14n") == etree.tostring(original, method="c14n")

"""A mined event in situ, end to end: a hand-written recording (one track starting late, one
ending early, one standing with backward jitter) -> the scenario -> the real esmini -> the
judge's numbers; bad input refused with one line naming the file and the track."""

from __future__ import annotations

import json

import numpy as np
import pytest
from lxml import etree
from scenariogeneration import xodr

from scenweave.judge.validate_xosc import xsd_findings
from scenweave.mining.in_situ import (
    InSituRefused,
    InSituSettings,
    RecordedRoad,
    choose,
    window_of,
    write_in_situ,
)
from scenweave.mining.tracks import LightPhase, Recording, Track, TrafficLight
from scenweave.scenario_lib.trajectories import hold_backward

SOURCE = "fixture/USA_Test-1_1_T-1.xml"
#: the standing car's recorded positions step back this far every third sample (m)
JITTER_M = 0.3


def _track(track_id: str, start: float, end: float, x0: float, speed: float, y: float,
           kind: str = "car", jitter: bool = False, length: float = 4.5) -> Track:
    t = np.round(np.arange(start, end + 1e-9, 0.1), 3)
    x = x0 + speed * (t - start)
    if jitter:
        x = x - np.where(np.arange(len(t)) % 3 == 1, JITTER_M, 0.0)
    n = len(t)
    return Track(track_id, length, 1.8, kind, t, x, np.full(n, y), np.zeros(n),
                 np.full(n, speed), x.copy(), np.array(["1"] * n))


def _recording(*extra: Track) -> Recording:
    tracks = [_track("1", 0.0, 10.0, 10.0, 10.0, -1.75),                 # the ego
              _track("2", 4.0, 7.0, 30.0, 8.0, -5.25),                   # starts late
              _track("3", 0.0, 10.0, 150.0, 0.0, 1.75, jitter=True),     # stands, jitters
              _track("4", 0.0, 5.0, 60.0, 12.0, -5.25, kind="truck", length=9.0)]  # ends early
    light = TrafficLight("40", ("1",), 100.0, (LightPhase(0.0, 4.5, "green"),
                                                LightPhase(4.5, 20.0, "red")))
    return Recording(SOURCE, 0.1, [*tracks, *extra], lights=[light], reader="commonroad")


RECORD = {"scenario_id": "FLF_mined_test", "provenance": {
    "file": SOURCE, "tracks": {"ego": "1"}, "start_s": 4.0, "end_s": 5.0}}


@pytest.fixture(scope="module")
def road(tmp_path_factory) -> RecordedRoad:
    folder = tmp_path_factory.mktemp("road")
    straight = xodr.create_road(xodr.Line(500), id=0, left_lanes=2, right_lanes=2)
    network = xodr.OpenDrive("straight")
    network.add_road(straight)
    network.adjust_roads_and_lanes()
    network.write_xml(str(folder / "road.xodr"))
    return RecordedRoad(folder / "road.xodr", {"40": ("9",)})


@pytest.fixture(scope="module")
def played(esmini, road, tmp_path_factory):
    out = tmp_path_factory.mktemp("event")
    return write_in_situ(_recording(), RECORD, out, road), out


def test_the_window_is_the_event_with_context_clipped_to_the_ego():
    choice = choose(_recording(), window_of(RECORD), context_s=3.0)
    assert (choice.start_s, choice.end_s) == (1.0, 8.0)
    names = [v.name for v in choice.vehicles]
    assert names == ["hero", "v2", "v3", "v4"]
    late = choice.vehicles[1]
    assert late.start_s == pytest.approx(3.0) and late.end_s == pytest.approx(6.0)
    assert choice.vehicles[0].properties == {"track_id": "1"}
    assert choice.held_samples > 0  # the standing car's backward steps


def test_every_vehicle_plays_its_record_except_the_held_jitter(played):
    result, _ = played
    verdict = result.verdict
    for name in ("hero", "v2", "v4"):
        fit = verdict.vehicles[name]
        assert fit.position_share == 1.0, (name, fit.to_dict())
        assert fit.worst_position_m < 0.02 and fit.heading_share == 1.0
        assert fit.speed_share == 1.0, (name, fit.to_dict())
    standing = verdict.vehicles["v3"]
    assert 0.05 < standing.worst_held_m <= JITTER_M  # held between its jittered positions
    assert standing.backward_samples > 0 and standing.position_share < 1.0
    assert standing.worst_position_m < 0.02  # where it follows the record, it is exact
    assert "IN_SITU_HELD" in [f.code for f in verdict.findings]
    assert not [f for f in verdict.findings if f.code == "IN_SITU_COLLISION"]


def test_no_car_steps_backwards_and_the_held_path_is_what_plays(played):
    result, _ = played
    replay = json.loads((result.folder / "replay.json").read_text())
    (raw,) = [p for p in result.choice.record if p.name == "v3"]
    times = np.round(np.array(replay["times"]), 3)
    played_x = np.array(replay["tracks"]["v3"]["x"])[np.isin(times, np.round(raw.t, 3))]
    assert (np.diff(played_x) >= -1e-3).all()  # heading 0: backwards is -x
    held_x = hold_backward(raw.x, raw.y, raw.heading)[0]
    assert played_x == pytest.approx(held_x, abs=0.006)  # thinned within 5 mm
    assert (np.diff(raw.x) < -0.2).any()  # while the record steps back


def test_a_steady_or_held_car_needs_few_vertices(played):
    result, _ = played
    vertices = {v.name: len(v.times) for v in result.choice.vehicles}
    samples = {p.name: len(p.t) for p in result.choice.record}
    assert vertices["hero"] == 2 < samples["hero"]  # constant speed: a straight line in time
    assert vertices["v3"] < samples["v3"] / 4  # held standing: its jitter is not played


def test_the_played_box_is_centred_on_the_recorded_centre(played):
    result, _ = played
    boxes = json.loads((result.folder / "replay.json").read_text())["boxes"]
    assert boxes["v4"] == [9.0, 1.8, 0.0]  # length, width, centre ahead of the reference


def test_the_late_and_the_early_vehicle_are_parked_outside_their_tracks(played):
    result, _ = played
    replay = json.loads((result.folder / "replay.json").read_text())
    times = np.array(replay["times"])
    late_y = np.array(replay["tracks"]["v2"]["y"])
    assert (late_y[times < 2.95] < -100).all() and (late_y[(times > 3.05) & (times < 6)] >
                                                     -10).all()
    early_y = np.array(replay["tracks"]["v4"]["y"])
    assert (early_y[times > 4.15] < -100).all()


def test_the_folder_holds_the_scenario_the_road_and_the_verdict(played):
    result, out = played
    assert sorted(p.name for p in result.folder.iterdir()) == [
        "in_situ.json", "judge.json", "replay.json", "road.xodr", "scenario.xosc"]
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no staging left
    tree = etree.parse(str(result.scenario))
    assert xsd_findings(tree) == []
    assert tree.find("RoadNetwork/LogicFile").get("filepath") == "road.xodr"
    phases = tree.findall("RoadNetwork/TrafficSignals/TrafficSignalController/Phase")
    assert [(float(p.get("duration")), p.find("TrafficSignalState").get("state"))
            for p in phases] == [(3.5, "green"), (3.5, "red")]
    judged = json.loads((result.folder / "judge.json").read_text())
    assert judged["vehicles"]["hero"]["position"]["share"] == 1.0
    assert not [f for f in judged["findings"] if f["code"] == "XSD_INVALID"]
    chosen = json.loads((result.folder / "in_situ.json").read_text())
    assert chosen["tracks"] == {"hero": "1", "v2": "2", "v3": "3", "v4": "4"}
    assert chosen["life_s"]["v2"] == [3.0, 6.0] and chosen["life_s"]["hero"] == [0.0, 7.0]


def test_the_external_hero_is_not_played_and_its_reference_is_kept(esmini, road, tmp_path):
    result = write_in_situ(_recording(), RECORD, tmp_path, road,
                           InSituSettings(external_ego=True))
    assert "hero" not in result.verdict.vehicles
    assert result.verdict.vehicles["v2"].position_share == 1.0
    rows = (result.folder / "hero_reference.csv").read_text().splitlines()
    assert rows[0] == "t,x,y,h" and len(rows) == 1 + 71
    assert rows[1].startswith("0.000,20.000,-1.750")
    root = etree.parse(str(result.scenario)).getroot()
    modules = [p.get("value") for p in root.iter("Property") if p.get("name") == "module"]
    assert modules == ["external_control"]


def test_a_track_with_a_gap_is_refused_naming_file_and_track(road, tmp_path):
    gap = _track("77", 0.0, 10.0, 80.0, 10.0, 1.75)
    keep = (gap.t < 3.0) | (gap.t > 3.55)
    holed = Track("77", 4.5, 1.8, "car", gap.t[keep], gap.x[keep], gap.y[keep],
                  gap.heading[keep], gap.speed[keep], gap.s[keep], gap.lane[keep])
    with pytest.raises(InSituRefused) as refused:
        write_in_situ(_recording(holed), RECORD, tmp_path, road, InSituSettings(replay=False))
    message = str(refused.value)
    assert "\n" not in message
    assert SOURCE in message and "track 77" in message and "gap" in message
    assert not list(tmp_path.iterdir()) or not (tmp_path / "in_situ").exists()


def test_a_vehicle_without_a_size_is_refused_naming_file_and_track(road, tmp_path):
    sizeless = _track("88", 0.0, 10.0, 80.0, 10.0, 1.75, length=float("nan"))
    with pytest.raises(InSituRefused, match=r"USA_Test-1_1_T-1\.xml: track 88 has no length"):
        write_in_situ(_recording(sizeless), RECORD, tmp_path, road,
                      InSituSettings(replay=False))
    assert not (tmp_path / "in_situ").exists()


def test_a_gap_outside_the_window_does_not_matter(road, tmp_path):
    late_gap = _track("99", 0.0, 10.0, 80.0, 10.0, 1.75)
    keep = late_gap.t < 9.0  # ends 1 s after the window: no gap inside it
    cut = Track("99", 4.5, 1.8, "car", late_gap.t[keep], late_gap.x[keep], late_gap.y[keep],
                late_gap.heading[keep], late_gap.speed[keep], late_gap.s[keep],
                late_gap.lane[keep])
    result = write_in_situ(_recording(cut), RECORD, tmp_path, road, InSituSettings(replay=False))
    assert result.verdict is None and (result.folder / "scenario.xosc").is_file()


def test_a_record_without_provenance_is_refused():
    with pytest.raises(InSituRefused, match="FLF_x: no provenance"):
        window_of({"scenario_id": "FLF_x"})


def _converter():
    return pytest.importorskip("scenweave.mining.recorded_road")


def test_a_road_that_cannot_be_converted_refuses_naming_file_and_lanelet(data, tmp_path):
    _converter()
    from scenweave.mining.in_situ import road_of

    root = etree.parse(str(data / "commonroad_small.xml")).getroot()
    lanelet = root.find("lanelet")
    first = lanelet.find("leftBound/point")
    for point in lanelet.findall("leftBound/point"):  # the left border shrinks to one point
        point.find("x").text, point.find("y").text = first.find("x").text, first.find("y").text
    bad = tmp_path / "USA_Bad-1_1_T-1.xml"
    bad.write_bytes(etree.tostring(root))
    with pytest.raises(InSituRefused) as refused:
        road_of(bad, tmp_path / "cache")
    message = str(refused.value)
    assert "\n" not in message and str(bad) in message
    assert f"lanelet {lanelet.get('id')}" in message


def test_a_commonroad_recording_plays_in_situ_on_its_converted_road(esmini, data, tmp_path):
    """The reader, the converter, the lights' signal ids and esmini together."""
    _converter()
    from scenweave.mining.in_situ import road_of
    from scenweave.mining.readers import read_file

    recording = read_file(data / "commonroad_small.xml")
    road = road_of(recording.source, tmp_path / "cache")
    ego = max(recording.tracks, key=lambda t: t.duration_s)
    window = {"scenario_id": "fixture", "provenance": {
        "file": recording.source, "tracks": {"ego": ego.id},
        "start_s": float(ego.t[0]) + 1.0, "end_s": float(ego.t[0]) + 2.0}}
    result = write_in_situ(recording, window, tmp_path / "event", road)
    verdict = result.verdict
    assert verdict is not None and verdict.passed, verdict.to_dict()["findings"]
    assert len(verdict.vehicles) == len([t for t in recording.tracks if len(t.t) >= 2])
    assert verdict.overall.position_share == 1.0
    controllers = etree.parse(str(result.scenario)).findall(
        "RoadNetwork/TrafficSignals/TrafficSignalController")
    signal_ids = {s.get("trafficSignalId") for c in controllers for s in c.iter(
        "TrafficSignalState")}
    assert signal_ids and signal_ids <= {i for ids in road.signals.values() for i in ids}


def test_a_batch_of_records_goes_on_past_refusals(esmini, data, tmp_path):
    """One record plays, one names a track its recording lacks, one a file whose road cannot
    be converted: two one-line refusals, the batch goes on, the report says it all."""
    _converter()
    from scenweave.mining.in_situ import write_in_situ_records
    from scenweave.mining.readers import read_file
    from scenweave.schemas.scenario_folder import IN_SITU_REPORT_NAME

    source = data / "commonroad_small.xml"
    ego = max(read_file(source).tracks, key=lambda t: t.duration_s)
    bad = tmp_path / "USA_Bad-1_1_T-1.xml"
    root = etree.parse(str(source)).getroot()
    for point in root.find("lanelet").findall("leftBound/point"):
        point.find("x").text, point.find("y").text = "0.0", "0.0"
    bad.write_bytes(etree.tostring(root))

    def record(name: str, file: object, track: str) -> dict:
        return {"scenario_id": name, "provenance": {"file": str(file), "tracks": {"ego": track},
                                                    "start_s": 1.0, "end_s": 2.0}}

    records = [record("good", source, ego.id), record("lost", source, "nobody"),
               record("unconvertible", bad, ego.id)]
    batch = write_in_situ_records(records, tmp_path / "in_situ", tmp_path / "cache")
    assert [r.folder.name for r in batch.written] == ["good"]
    assert (tmp_path / "in_situ" / "good" / "scenario.xosc").is_file()
    assert len(batch.refused) == 2 and all("\n" not in line for line in batch.refused)
    lost, unconvertible = sorted(batch.refused)
    assert lost.startswith("lost: ") and str(source) in lost and "track nobody" in lost
    assert unconvertible.startswith("unconvertible: ") and str(bad) in unconvertible
    assert "lanelet" in unconvertible
    report = json.loads((tmp_path / "in_situ" / IN_SITU_REPORT_NAME).read_text())
    assert report["refused"] == batch.refused and report["written"][0]["passed"] is True



@pytest.mark.parametrize("place, snippet", [("us101", "USA_US101-9_1_T-1.xml"),
                                            ("lankershim", "USA_Lanker-1_10_T-1.xml")])
def test_a_mined_event_of_the_shared_data_plays_in_situ(esmini, ngsim_snippets, tmp_path, place,
                                                        snippet):
    """Real NGSIM traffic on its converted road: the first mined record of a file, every
    vehicle around it within 0.1 m of the raw record at >= 99 % of samples (what misses is a
    standing car's backward jitter, held), none beyond 0.5 m, no collision the record
    lacks; an urban file's lights as controllers."""
    _converter()
    from scenweave.ingest import load_records
    from scenweave.mining.in_situ import road_of
    from scenweave.mining.mine import mine_recordings
    from scenweave.mining.readers import read_file
    from scenweave.mining.thresholds import load_thresholds

    source = ngsim_snippets / place / snippet
    if not source.is_file():
        pytest.skip(f"{source} is not in the shared data")
    recording = read_file(source)
    mine_recordings([recording], tmp_path / "records", load_thresholds())
    record = next(iter(load_records(tmp_path / "records")))
    road = road_of(recording.source, tmp_path / "cache")
    result = write_in_situ(recording, record, tmp_path / "event", road)
    overall = result.verdict.overall
    assert len(result.verdict.vehicles) > 3
    assert overall.position_share >= 0.99, result.verdict.to_dict()["findings"]
    assert overall.worst_position_m <= 0.5
    assert not [f for f in result.verdict.findings if f.code in ("IN_SITU_COLLISION",
                                                                 "IN_SITU_ENGINE")]
    if place == "lankershim":
        controllers = etree.parse(str(result.scenario)).findall(
            "RoadNetwork/TrafficSignals/TrafficSignalController")
        assert controllers

"""Issue 36, item 1: cars recorded close together in town are placed without overlap, or the
record is refused with the geometric reason before any scenario is written.

A town record's lead is measured bumper to bumper (ADScene ``pos_x``; mined records write the
bumper gap); a scenario places vehicles by their reference points (the rear axle). Placed as
a reference-point distance, a lead 2.4 m ahead in a queue stood on the ego's bonnet: the
replay's collision at 0.00 s (Lankershim U1_1 and U4_3 rows). The fixtures below are ADScene
objects in the shape of those rows; the last tests read the shared town snippets themselves.
A mined record's lead-in (both cars at their start speeds before the manoeuvre) is cut short
where a car of the ego's lane would otherwise have started on it.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenweave import corpus, maneuvers
from scenweave.ingest import admit
from scenweave.ingest.extract import lead_in_s
from scenweave.ingest.issues import RecordIssue
from scenweave.ingest.playable import MIN_BUMPER_GAP_M, check_playable
from scenweave.ingest.urban import canonicalize_scene
from scenweave.scenario_lib.kinematics import start_gap_m
from scenweave.scenario_lib.vehicles import bumper_gap_m, reference_gap_m
from tests.ingest.builders import obstacle, scene

#: the shared NGSIM snippets; the town ones are in lankershim/ and peachtree/
TOWN = Path("/work/shared/data/ngsim")
#: the ADScene code of a green light (RT_TrafficSignType)
GREEN = 167


def queue_on_green(lead_bumper_gap_m: float) -> dict:
    """A U4_3 record in the shape of Lankershim 2-10 row 13: the ego stands in a queue behind
    a standing car ``lead_bumper_gap_m`` ahead, the light turns green and both drive off."""
    speeds = [0.0, 2.0, 4.0, 6.0, 8.0]
    frames = [[obstacle(7, lead_bumper_gap_m, v, v)] for v in speeds]
    return scene("U4_3", [v * 3.6 for v in speeds], [0.0, 1.0, 2.0, 3.0, 4.0],
                 [0.0, 1.0, 4.0, 9.0, 16.0], light=(30.0, GREEN), obstacles=frames)


def test_a_queued_lead_is_placed_by_its_bumper_gap():
    params = admit(canonicalize_scene(queue_on_green(2.4), "U4_3/queue.json"))
    assert params["lead_present"] is True and params["ego_speed_ms"] == 0.0
    # the reference points stand further apart than the bumpers, by the two overhangs
    assert params["lead_distance_m"] == pytest.approx(reference_gap_m(2.4, "car"))
    assert bumper_gap_m(params["lead_distance_m"], "car") == pytest.approx(2.4)


def test_a_lead_closer_than_the_least_bumper_gap_is_refused_with_the_reason():
    with pytest.raises(RecordIssue) as refused:
        admit(canonicalize_scene(queue_on_green(MIN_BUMPER_GAP_M / 2), "U4_3/touching.json"))
    assert refused.value.field == "lead_distance_m"
    assert "overlap at the start" in str(refused.value)


def test_side_by_side_takes_the_sign_of_its_zero():
    """A cut-in behind whose car starts level with the ego writes a bumper gap of -0.0: it is
    behind, not ahead (Peachtree 2 CINB row 0 was placed ahead and cut in on the ego)."""
    assert reference_gap_m(-0.0, "car") < -1.0
    assert reference_gap_m(0.0, "car") > 1.0


def test_a_follower_catching_up_gets_a_shorter_lead_in():
    """A car 7.76 m behind (reference points) at 2.84 m/s, the ego at 5.14 m/s (Lankershim
    2-16 FLB row 1): 2 s before the record they overlapped; the lead-in stops where its
    bumper is still 0.5 m behind the ego's. A slower gap change keeps the full 2 s."""
    follow = maneuvers.get("FLB").same_lane
    params = {"has_npc": True, "npc_distance_m": -7.76, "npc_speed_ms": 2.84,
              "ego_speed_ms": 5.14, "npc_vehicle_type": "car"}
    lead_in = lead_in_s(params, follow)
    assert 0.0 < lead_in < 2.0
    at_zero = start_gap_m(-7.76, 2.84, 5.14, lead_in)
    assert -bumper_gap_m(at_zero, "car") >= MIN_BUMPER_GAP_M
    assert -bumper_gap_m(start_gap_m(-7.76, 2.84, 5.14, lead_in + 0.2), "car") \
        < MIN_BUMPER_GAP_M
    assert lead_in_s(params | {"npc_speed_ms": 4.5}, follow) == 2.0
    assert lead_in_s(params, None) == 2.0  # no car of the ego's lane: nothing to keep


def test_side_by_side_only_in_tracking_noise_is_no_overlap():
    """A car behind whose recorded box jumps level with the ego while the record names its
    position tracking noise (Lankershim 2-10, FL of cars 2704 and 2713) was never beside it:
    the record is admitted. Level with it in clean samples, it is refused, naming the time."""
    series = {"t": [0.0, 0.1, 0.2, 0.3], "npc_gap_m": [-4.0, -0.0, -0.0, -3.9],
              "npc_lane": [1.0] * 4, "ego_lane": [1.0] * 4,
              "npc_noise": [0.0, 1.0, 0.0, 0.0], "ego_noise": [0.0, 0.0, 1.0, 0.0]}
    params = {"domain": "highway", "maneuver_class": "FLB", "has_npc": True,
              "recorded_series": series}
    check_playable(params)
    series["ego_noise"] = [0.0] * 4
    with pytest.raises(RecordIssue, match="side by side with the ego at 0.20 s"):
        check_playable(params)


@pytest.mark.slow
@pytest.mark.usefixtures("esmini")
def test_the_queue_plays_without_a_collision(tmp_path):
    """Spawned on Town04 and played in esmini, the queue's two cars never touch."""
    from scenweave.judge import validate_xosc
    from scenweave.player import ReplaySettings
    from scenweave.spawn_db import SpawnMatcher

    params = SpawnMatcher().assign(admit(canonicalize_scene(queue_on_green(2.4), "q.json")), 0)
    path = corpus.generate(dict(params), tmp_path / "queue.xosc")
    result = validate_xosc(path, params, replay=ReplaySettings())
    codes = {f.code for f in result.errors}
    assert "REPLAY_COLLISION" not in codes, [f.message for f in result.errors]
    assert result.valid, [f"{f.code}: {f.message}" for f in result.errors]


@pytest.fixture(scope="module")
def town_records(tmp_path_factory) -> list[dict]:
    """The records mined from every shared town snippet, Lankershim and Peachtree (skips
    where the shared data is absent)."""
    snippets = [xml for place in ("lankershim", "peachtree")
                for xml in sorted((TOWN / place).glob("*.xml"))]
    if not snippets:
        pytest.skip("shared NGSIM town data absent")
    from scenweave.mining.mine import mine_recordings
    from scenweave.mining.readers import read_recordings
    from scenweave.mining.thresholds import load_thresholds

    root = tmp_path_factory.mktemp("town")
    (root / "in").mkdir()
    for snippet in snippets:
        (root / "in" / snippet.name).symlink_to(snippet)
    report = mine_recordings(read_recordings(root / "in"), root / "out", load_thresholds())
    assert all(s.get("field") != "lead_distance_m" or "overlap" in s["reason"]
               for s in report.to_dict()["skipped"])
    return [record for path in sorted((root / "out").glob("*/*.json"))
            for record in json.loads(path.read_text())]


def test_every_mined_town_lead_stands_clear_of_the_ego(town_records):
    """Every urban event mined from the town snippets (their queues at the junctions
    included) places its lead with the bumpers apart (mining refuses the others, naming the
    field)."""
    leads = 0
    for record in town_records:
        if record.get("version") != "urban.v1":
            continue
        params = admit(record)
        if params["lead_present"]:
            leads += 1
            gap = bumper_gap_m(params["lead_distance_m"], params["lead_vehicle_type"])
            assert gap is not None and gap >= MIN_BUMPER_GAP_M, params["scenario_id"]
    assert leads >= 5


def test_every_car_of_the_egos_lane_starts_clear_of_it(town_records):
    """A mined highway-class record's cars hold their start speeds for a lead-in before the
    manoeuvre; in town their speeds differ so much that 2 s earlier a follower stood on the
    ego's boot (Lankershim 2-16 FLB row 1, 2-6 FLF row 3: collisions at 0.00 s). The lead-in
    is cut short where needed: at t = 0 every car of the ego's lane keeps its bumper apart."""
    shortened = 0
    for record in town_records:
        if record.get("domain") != "highway":
            continue
        params = admit(record)
        same_lane = maneuvers.get(params["maneuver_class"]).same_lane
        if same_lane is None or not (params.get(f"{same_lane.prefix}_present")
                                     or same_lane.prefix == "npc" and params["has_npc"]):
            continue
        prefix = same_lane.prefix
        at_zero = start_gap_m(params[f"{prefix}_distance_m"], params[f"{prefix}_speed_ms"],
                              params["ego_speed_ms"], params["maneuver_start_s"])
        gap = bumper_gap_m(at_zero, params.get(f"{prefix}_vehicle_type"))
        assert gap is not None and abs(gap) >= MIN_BUMPER_GAP_M - 1e-6, params["scenario_id"]
        shortened += params["maneuver_start_s"] < 2.0
    assert shortened >= 1


@pytest.mark.slow
@pytest.mark.usefixtures("esmini")
def test_the_mined_queues_start_standing_and_play(town_records, tmp_path):
    """Issue 36 items 1 and 2 on the record: the town U4_3 events whose ego
    stands (or creeps) in a queue behind its lead when the light turns green start standing,
    drive off, and play without a collision (before: 5 collided at 0.00 s)."""
    from scenweave.judge import validate_xosc
    from scenweave.player import ReplaySettings
    from scenweave.spawn_db import SpawnMatcher

    queued = [admit(r) for r in town_records if r["maneuver_class"] == "U4_3"]
    queued = [p for p in queued if p["lead_present"] and p["ego_speed_ms"] < 1.0]
    assert len(queued) >= 3
    queued = queued[:6]  # each plays for seconds on a loaded machine
    matcher = SpawnMatcher()
    for number, record_params in enumerate(queued):
        params = matcher.assign(record_params, number)
        path = corpus.generate(dict(params), tmp_path / f"{number}.xosc")
        result = validate_xosc(path, params, replay=ReplaySettings())
        assert result.valid, (params["scenario_id"],
                              [f"{f.code}: {f.message}" for f in result.errors])

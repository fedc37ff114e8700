"""Can a scenario play this record back? Params a replay cannot reproduce become input issues.

Extraction reads what a record says; this asks whether the scenario ScenWeave would make of it
can show it when played: both cars change speed linearly over the record, no vehicle brakes
harder than ``MAX_PLAYABLE_DECELERATION_MS2``, and two cars of one lane stay their safety
distance apart (``corpus_utils.clearance_m``, reference point to reference point). A record
that fails gets one issue naming its file, row and the field at fault, instead of a scenario
whose replay shows a collision or a gap the record never had.
"""

from __future__ import annotations

from scenweave import maneuvers
from scenweave.corpus.corpus_utils import clearance_m
from scenweave.corpus.kinematics import MAX_PLAYABLE_DECELERATION_MS2, SpeedProfile, min_gap_m
from scenweave.ingest.issues import RecordIssue
from scenweave.maneuvers import SameLane
from scenweave.schemas.replay import GAP_TOL_M


def check_playable(params: dict) -> None:
    """Raise ``RecordIssue`` (naming the file's field) when no replay can show ``params``."""
    if params.get("domain") != "highway":
        return
    maneuver = maneuvers.get(params["maneuver_class"])
    if maneuver.lead_brakes:
        _brakes_as_a_car_can(params)
    if maneuver.gap_at_end:
        _end_gap_follows_from_speeds(params)
    if maneuver.npc_ends_in_ego_lane and maneuver.npc_position == "behind":
        _merges_behind(params)
    if maneuver.same_lane is not None:
        _cars_in_one_lane_stay_apart(params, maneuver.same_lane)


def _profile(params: dict, prefix: str) -> SpeedProfile:
    return SpeedProfile(params[f"{prefix}_speed_ms"], params[f"{prefix}_end_speed_ms"], 0.0,
                        params["duration_s"])


def _brakes_as_a_car_can(params: dict) -> None:
    slowed, duration = params["npc_speed_ms"] - params["npc_end_speed_ms"], params["duration_s"]
    if duration > 0 and slowed / duration > MAX_PLAYABLE_DECELERATION_MS2:
        raise RecordIssue(
            f"the lead slows by {slowed:.1f} m/s within {duration:g} s "
            f"({slowed / duration:.1f} m/s^2): harder than any car brakes "
            f"(scenarios allow {MAX_PLAYABLE_DECELERATION_MS2:g} m/s^2), no replay can show it",
            field="delta_vel_kmh")


def _gained_m(params: dict) -> float:
    """How much the NPC gains on the ego over the record (m; negative: it drops back)."""
    duration = params["duration_s"]
    return _profile(params, "npc").distance(duration) - _profile(params, "ego").distance(duration)


def _end_gap_follows_from_speeds(params: dict) -> None:
    """A following record's end gap is what its speeds make of its start gap."""
    begin, end = params["npc_distance_m"], params["npc_distance_end_m"]
    made = begin + _gained_m(params)
    if abs(made - end) > GAP_TOL_M:
        raise RecordIssue(
            f"the gap (reference points) goes from {begin:.1f} m to {end:.1f} m, but the speeds "
            f"make it {made:.1f} m after {params['duration_s']:g} s (they differ by more than "
            f"{GAP_TOL_M:g} m): no replay can show both", field="npc_distance_end_m")


def _merges_behind(params: dict) -> None:
    """A cut-in behind ends with the car behind the ego (the ego keeps its speed)."""
    duration, gained = params["duration_s"], _gained_m(params)
    end_gap = params["npc_distance_m"] + gained
    room = clearance_m(params.get("npc_vehicle_type"))
    if end_gap > -room:
        raise RecordIssue(
            f"the car merging behind starts {params['npc_distance_m']:.1f} m behind the ego and "
            f"gains {gained:.1f} m in {duration:g} s: it would end {end_gap:.1f} m from the "
            f"ego's reference point, not behind it (at least {room:.1f} m)",
            field="npc_distance_m")


def _cars_in_one_lane_stay_apart(params: dict, same_lane: SameLane) -> None:
    """Two cars of one lane never come closer than their safety distance: at t = 0, and for a
    car that stays in the lane, while both change speed over the record (a slower car ahead
    that speeds up only later is run into half way, whatever the end gap says)."""
    prefix, column = same_lane.prefix, same_lane.gap_column
    if prefix != "npc" and not params.get(f"{prefix}_present"):
        return
    gap, kind = params[f"{prefix}_distance_m"], params.get(f"{prefix}_vehicle_type")
    until = params["duration_s"] if same_lane.span == "all_along" else 0.0
    ego, other = _profile(params, "ego"), _profile(params, prefix)
    lead, follower = (other, ego) if gap >= 0 else (ego, other)
    closest = min_gap_m(lead, follower, abs(gap), until)
    room = clearance_m(kind)
    if closest < room:
        when = "at the start" if until == 0 or closest >= abs(gap) - 1e-9 else \
            "as both change speed over the record"
        raise RecordIssue(
            f"the {kind or 'car'} in the ego's lane comes {closest:.1f} m from the ego "
            f"(reference points; {room:.1f} m keeps them apart) {when}: no replay can show "
            "the record without a collision", field=column)

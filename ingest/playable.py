"""Can a scenario play this record back? Only records no scenario can show become input issues.

Extraction reads what a record says and fits each actor's speed phases (``ingest.phases``);
this asks whether **any** profile the phase model allows can show the record, not whether one
ramp can: no vehicle changes speed harder than ``MAX_PLAYABLE_DECELERATION_MS2``, a recorded
end gap is reachable by some profile, a car merging behind ends behind, and two cars of one
lane never overlap. Clearance is one rule ahead and behind, in bumper terms: the facing
bumpers stay ``MIN_BUMPER_GAP_M`` apart (docs/scenario-conventions.md, "Replay"). A record
that fails gets one issue naming its file, row, the field at fault and why no profile fits.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from scenweave import maneuvers
from scenweave.ingest.extract import npc_end_gap_phases
from scenweave.ingest.issues import RecordIssue
from scenweave.ingest.phases import NoProfile
from scenweave.maneuvers import SameLane
from scenweave.scenario_lib.kinematics import MAX_PLAYABLE_DECELERATION_MS2, min_gap_m
from scenweave.scenario_lib.phases import PhasedProfile, phases_of, profile_of
from scenweave.scenario_lib.vehicles import MIN_BUMPER_GAP_M, least_reference_gap_m

#: arithmetic noise below what any field records (m)
ROUNDING_M = 1e-6


def check_playable(params: Mapping[str, Any]) -> None:
    """Raise ``RecordIssue`` (naming the file's field) when no replay can show ``params``."""
    if params.get("domain") == "urban":
        _urban_lead_apart(params)
    if params.get("domain") != "highway":
        return
    maneuver = maneuvers.get(params["maneuver_class"])
    recorded = params.get("recorded_series") is not None
    if maneuver.lead_brakes:
        _brakes_as_a_car_can(params)
    if maneuver.gap_at_end and not recorded:
        _end_gap_reachable(params)
    if maneuver.npc_ends_in_ego_lane and maneuver.npc_position == "behind":
        _merges_behind(params)
    if maneuver.same_lane is not None:
        if recorded:
            _recorded_gaps_never_overlap(params, maneuver.same_lane)
        else:
            _cars_in_one_lane_stay_apart(params, maneuver.same_lane)


def _brakes_as_a_car_can(params: Mapping[str, Any]) -> None:
    profile = PhasedProfile(params["npc_speed_ms"], phases_of(params, "npc"))
    hardest = profile.max_acceleration_ms2(braking_only=True)
    if hardest > MAX_PLAYABLE_DECELERATION_MS2:
        slowed = params["npc_speed_ms"] - profile.end_speed
        raise RecordIssue(
            f"the lead slows by {slowed:.1f} m/s at up to {hardest:.1f} m/s^2: harder than any "
            f"car brakes (scenarios allow {MAX_PLAYABLE_DECELERATION_MS2:g} m/s^2), no speed "
            "profile can show it", field="delta_vel_kmh")


def _end_gap_reachable(params: Mapping[str, Any]) -> None:
    """A following record's end gap needs a profile of the NPC that covers the distance."""
    try:
        npc_end_gap_phases(params)
    except NoProfile as err:
        raise RecordIssue(
            f"the gap (reference points) goes from {params['npc_distance_m']:.1f} m to "
            f"{params['npc_distance_end_m']:.1f} m in {params['duration_s']:g} s while the "
            f"speeds go {params['npc_speed_ms']:.1f} -> {params['npc_end_speed_ms']:.1f} m/s "
            f"(NPC) and {params['ego_speed_ms']:.1f} -> {params['ego_end_speed_ms']:.1f} m/s "
            f"(ego): no speed profile fits, {err}", field="npc_distance_end_m") from err


def _urban_lead_apart(params: Mapping[str, Any]) -> None:
    """The urban lead stands ahead of the ego in its lane with their bumpers apart: a queue
    closer than that cannot be placed on any map without the two overlapping at t = 0."""
    if not params.get("lead_present"):
        return
    kind = params.get("lead_vehicle_type")
    gap, room = params["lead_distance_m"], least_reference_gap_m(kind, ahead=True)
    if gap < room - ROUNDING_M:
        raise RecordIssue(
            f"the {kind or 'car'} ahead stands {gap:.2f} m from the ego (reference points; its "
            f"rear bumper {MIN_BUMPER_GAP_M:g} m from the ego's front is {room:.2f} m): in one "
            "lane the two would overlap at the start", field="lead_distance_m")


def _gained_m(params: Mapping[str, Any]) -> float:
    """How much the NPC gains on the ego over the record (m; negative: it drops back)."""
    start, end = params["maneuver_start_s"], params["maneuver_start_s"] + params["duration_s"]
    npc, ego = profile_of(params, "npc"), profile_of(params, "ego")
    return npc.distance(end) - npc.distance(start) - ego.distance(end) + ego.distance(start)


def _merges_behind(params: Mapping[str, Any]) -> None:
    """A cut-in behind ends with the car behind the ego, bumpers apart."""
    duration, gained = params["duration_s"], _gained_m(params)
    end_gap = params["npc_distance_m"] + gained
    room = least_reference_gap_m(params.get("npc_vehicle_type"), ahead=False)
    if end_gap > -room + ROUNDING_M:
        raise RecordIssue(
            f"the car merging behind starts {params['npc_distance_m']:.1f} m behind the ego and "
            f"gains {gained:.1f} m in {duration:g} s: it would end {end_gap:.1f} m from the "
            f"ego's reference point, not behind it (its bumper {MIN_BUMPER_GAP_M:g} m behind "
            f"the ego's is {room:.1f} m)", field="npc_distance_m")


def _present(params: Mapping[str, Any], same_lane: SameLane) -> bool:
    return same_lane.prefix == "npc" or bool(params.get(f"{same_lane.prefix}_present"))


def _cars_in_one_lane_stay_apart(params: Mapping[str, Any], same_lane: SameLane) -> None:
    """Two cars of one lane keep their bumpers apart: at t = 0, and for a car that stays in
    the lane, while both drive their profiles over the record."""
    prefix, column = same_lane.prefix, same_lane.gap_column
    if not _present(params, same_lane):
        return
    gap, kind = params[f"{prefix}_distance_m"], params.get(f"{prefix}_vehicle_type")
    start = params["maneuver_start_s"]
    until = start + params["duration_s"] if same_lane.span == "all_along" else start
    ego, other = profile_of(params, "ego"), profile_of(params, prefix)
    ahead = gap >= 0
    lead, follower = (other, ego) if ahead else (ego, other)
    at_zero = abs(gap) - (lead.distance(start) - follower.distance(start))
    # min_gap_m reads any profile's breakpoints and distances; its annotation names only
    # SpeedProfile until corpus (being edited this round) types it with a Protocol
    closest = min_gap_m(lead, follower, at_zero, until, from_s=start)  # type: ignore[arg-type]
    room = least_reference_gap_m(kind, ahead)
    if closest < room - ROUNDING_M:
        when = "at the start" if until == start or closest >= abs(gap) - 1e-9 else \
            "as both drive their recorded speeds"
        raise RecordIssue(
            f"the {kind or 'car'} {'ahead of' if ahead else 'behind'} the ego comes "
            f"{closest:.1f} m from it (reference points; its bumper {MIN_BUMPER_GAP_M:g} m from "
            f"the ego's is {room:.1f} m) {when}: the two would overlap, no replay can show it",
            field=column)


def _recorded_gaps_never_overlap(params: Mapping[str, Any], same_lane: SameLane) -> None:
    """A mined record's own bumper gaps: a car the class keeps in the ego's lane that is ever
    side by side with the ego (gap 0) cannot be played without the two overlapping."""
    if not _present(params, same_lane):
        return
    series, prefix = params["recorded_series"], same_lane.prefix
    gaps = series.get(f"{prefix}_gap_m") or []
    lanes = zip(series.get(f"{prefix}_lane") or [None] * len(gaps),
                series.get("ego_lane") or [None] * len(gaps), strict=False)
    noise = _noise(series, (prefix, "ego"), len(gaps))
    for t, gap, (lane, ego_lane), noisy in zip(series["t"], gaps, lanes, noise, strict=False):
        # a gap of 0 is side by side: in one lane an overlap; beside it, the car left the
        # ego's lane, which the class's scenario (the car keeps the ego's lane) cannot show.
        # Not where the record names either car's position tracking noise (a box jumping a
        # metre ahead and back): no car was there (Lankershim 2-10 FL of 2704 and 2713)
        if gap == 0.0 and t is not None and not noisy:
            where = "" if None in (lane, ego_lane) else \
                f" (recorded in lane {lane:g}, the ego in lane {ego_lane:g})"
            raise RecordIssue(f"the car the class keeps in the ego's lane is side by side with "
                              f"the ego at {t:.2f} s{where}: in one lane they would overlap",
                              field=f"series.{prefix}_gap_m")


def _noise(series: Mapping[str, Any], roles: tuple[str, ...], count: int) -> list[bool]:
    """Per sample, whether the record names any of ``roles``' positions tracking noise
    (``<role>_noise``, docs/scenario-conventions.md)."""
    flags = [series.get(f"{role}_noise") or [] for role in roles]
    return [any(bool(f[i]) for f in flags if i < len(f)) for i in range(count)]

"""Does a mined event survive the trip through a scenario? Mine the replay again and compare.

The played scenario (``replay.json``) becomes a recording (``mining.replayed``); the same
detectors must find the same class with the ego and the NPC in the same roles, and its fields
must be the record's within the tolerances: speeds 0.5 m/s, gaps 1 m, times 0.2 s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from scenweave import maneuvers
from scenweave.ingest import extract_params
from scenweave.mining.detect import KMH, Event, Scene, detect
from scenweave.mining.highway import follow_event, free_ride_event
from scenweave.mining.replayed import recording_from_playback
from scenweave.mining.tracks import Recording
from scenweave.player import Playback
from scenweave.scenario_lib.kinematics import GAP_TOL_M

SPEED_TOL_MS = 0.5
TIME_TOL_S = 0.2
GAP_FIELDS = ("npc_distance_m", "npc_distance_begin_m", "npc_distance_end_m")


@dataclass
class RoundTrip:
    """The record's class and id, whether it held, and each field that missed."""

    code: str
    scenario_id: str
    found: bool
    misses: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def holds(self) -> bool:
        return self.found and not self.misses

    @property
    def worst(self) -> str:
        if not self.found:
            return "not found again"
        name, (want, got) = max(self.misses.items(), key=lambda m: _excess(m[0], *m[1]))
        return f"{name} {want:g} -> {got:g}"


def round_trip(record: dict, playback: Playback,
               thresholds: dict[str, dict[str, float]]) -> RoundTrip:
    """Mine ``playback`` (the record's scenario, played) and compare with ``record``."""
    recording = recording_from_playback(playback, record["scenario_id"])
    thresholds = exact(thresholds)
    roles = record.get("provenance", {}).get("tracks", {})
    code = record["maneuver_class"]
    alone = "npc" not in roles
    candidates = [e for e in detect(recording, thresholds) if _shows(code, e.code, alone)
                  and e.ego == "ego" and (e.npc is None if alone else e.npc == "npc")]
    result = RoundTrip(code, record["scenario_id"], bool(candidates))
    maneuver = maneuvers.get(code)
    if candidates and (maneuver.gap_at_end or maneuver.surrounding_slots):
        candidates = _same_window(recording, record, thresholds)
    if candidates:
        best = min(candidates, key=lambda e: len(_misses(record["params"], e)))
        result.misses = _misses(record["params"], best)
    return result


def exact(thresholds: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
    """The thresholds for a replay. esmini reports exact speeds: smoothing them would blur
    the played motion a second time. And a replay within the speed tolerance of the record
    may brake up to twice that tolerance softer within a second and over the phase: a
    scenario that plays the recorded speeds within 0.5 m/s shows the brake it was mined as."""
    brake = thresholds["brake"]
    slack = 2 * SPEED_TOL_MS
    return {**thresholds, "smoothing": {**thresholds["smoothing"], "window_s": 0.0},
            "brake": {**brake, "deceleration_ms2": max(brake["deceleration_ms2"] - slack, 0.0),
                      "min_speed_drop_ms": max(brake["min_speed_drop_ms"] - slack, 0.0)}}


def _shows(code: str, found: str, alone: bool) -> bool:
    """Whether an event of class ``found`` in the replay is the record's ``code``. The ego's
    own lane change seen from the front or the rear (LCF, LCB) differs only in where the
    nearest car of its new lane is; a scenario that plays the ego alone has no such car, so
    there either view is the same manoeuvre."""
    if found == code:
        return True
    wanted, seen = maneuvers.get(code), maneuvers.get(found)
    return alone and wanted.lane_change == seen.lane_change == "hero"


def _same_window(recording: Recording, record: dict,
                 thresholds: dict[str, dict[str, float]]) -> list[Event]:
    """A following record or a free ride is a window cut out of a longer episode (the
    scenario plays on past it): measure the replay over the record's own window (the
    manoeuvre's start to its end in the scenario)."""
    scene = Scene(recording, thresholds)
    ids = [track.id for track in recording.tracks]
    code = record["maneuver_class"]
    start = float(extract_params(record)["maneuver_start_s"])
    end = start + float(record["params"]["duration_s"])
    if "ego" not in ids:
        return []
    if maneuvers.get(code).surrounding_slots:
        event = free_ride_event(scene, code, ids.index("ego"), start, end,
                                maneuvers.get(code).npc_position == "front",
                                thresholds["free_ride"])
    elif "npc" in ids:
        event = follow_event(scene, code, ids.index("ego"), ids.index("npc"), start, end,
                             thresholds["follow"])
    else:
        event = None
    return [] if event is None else [event]


def _misses(wanted: dict, event: Event) -> dict[str, tuple[float, float]]:
    found = {}
    for name, want in wanted.items():
        got = event.fields.get(name)
        if not isinstance(want, int | float) or not isinstance(got, int | float):
            continue
        if _excess(name, want, got) > 0:
            found[name] = (want, got)
    return found


def _excess(name: str, want: float, got: float) -> float:
    """How far past its tolerance a field is (<= 0: within it); fields without one: 0."""
    if name.endswith("_kmh"):
        return abs(want - got) / KMH - SPEED_TOL_MS
    if name in GAP_FIELDS:
        return abs(want - got) - GAP_TOL_M
    if name == "duration_s":
        return abs(want - got) - TIME_TOL_S
    return 0.0

"""A mined :class:`Event` -> the canonical record of its class, as ingest would write it from
a MOOVE file, plus where it was found (``provenance``), what was recorded (``series``) and how
critical it was (``criticality``: ``mining.criticality``)."""

from __future__ import annotations

import math
from pathlib import Path

from scenweave import maneuvers
from scenweave.ingest.layouts import default_layouts
from scenweave.ingest.urban import canonicalize_scene
from scenweave.mining.criticality import criticality
from scenweave.mining.scene import Event

BINNING = "mined"


def highway_record(event: Event, source: Path, reader: str, number: int) -> dict:
    """The phase1.v1 record of a highway event; gaps are between bumpers, a relative speed is
    npc minus ego (``conventions``)."""
    maneuver = maneuvers.get(event.code)
    has_npc, position = _npc(maneuver, event)
    conventions: dict = {"gaps_between": "bumpers"}
    if maneuver.relative_speed:
        conventions["relative_speed_sign"] = 1
    if maneuver.surrounding_slots:  # a free ride's empty slots, as the bundled layout marks them
        conventions["sentinels"] = default_layouts().classes[event.code].conventions["sentinels"]
    if maneuver.npc_ends_in_ego_lane:
        conventions["direction_is"] = "move"  # the cutter's own move (docs/highway-layouts.md)
    stem = _slug(source.stem)
    return {
        "schema_version": "phase1.v1",
        "scenario_id": f"{event.code}_{BINNING}_{stem}_row{number:06d}",
        "maneuver_class": event.code,
        "maneuver_tag": maneuver.tag,
        "domain": "highway",
        "has_npc": has_npc,
        "npc_position": position,
        "binning_version": BINNING,
        "source": {"file": source.name, "row_index": number},
        "behavior_type": event.fields.get("behavior_type"),
        "params": dict(event.fields),
        "conventions": conventions,
        "provenance": _provenance(event, source, reader),
        "criticality": criticality(event.series),
        "series": event.series,
    }


def record_of(event: Event, source: Path, reader: str, number: int) -> dict:
    """The canonical record of an event, highway or urban."""
    if event.adscene is None:
        return highway_record(event, source, reader, number)
    return urban_record(event, source, reader, number)


def urban_record(event: Event, source: Path, reader: str, number: int) -> dict:
    """The urban.v1 record of a light event: its ADScene object through ingest's own
    canonicaliser (RecordIssue where it is no valid scene)."""
    if event.adscene is None:
        raise ValueError(f"{event.code} event of {event.ego}: not urban (no ADScene object)")
    name = f"{event.code}/{_slug(source.stem)}-row{number:06d}.json"
    record = canonicalize_scene(event.adscene, name, notes=[])
    record["provenance"] = _provenance(event, source, reader)
    record["criticality"] = criticality(event.series)
    record["series"] = event.series
    return record


def _provenance(event: Event, source: Path, reader: str) -> dict:
    return {"file": str(source), "reader": reader,
            "tracks": {"ego": event.ego} | ({"npc": event.npc} if event.npc else {}),
            "start_s": event.start_s, "end_s": event.end_s}


def _npc(maneuver: maneuvers.Maneuver, event: Event) -> tuple[bool, str | None]:
    if maneuver.surrounding_slots:  # a free ride: any surrounding vehicle
        present = any(key.endswith("_speed_ms") and key != "ego_speed_ms"
                      for key in event.series)
        return present, maneuver.npc_position if present else None
    if event.npc is None:
        return False, None
    distance = event.fields.get("npc_distance_m")
    if isinstance(distance, float | int):
        return True, "front" if math.copysign(1.0, distance) > 0 else "behind"
    return True, maneuver.npc_position


def _slug(text: str) -> str:
    """File stems as scenario-id parts: letters, digits, dots and dashes."""
    return "".join(c if c.isalnum() or c in ".-" else "-" for c in text)

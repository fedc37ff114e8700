"""Recordings in, canonical records of every manoeuvre found out (``scenweave mine``).

Output, as ``scenweave ingest`` writes it (``scenweave run`` reads it directly):
``<out>/highway/<CLASS>.json`` (arrays of records) and ``<out>/mining_report.json``: events per
class and file, the parameters' values (for histograms), what was skipped and why, and how
much driving was mined how fast.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from scenweave.files.atomic import write_json_atomic
from scenweave.ingest import admit, extract_params
from scenweave.ingest.issues import RecordIssue
from scenweave.mining.detect import Event, detect
from scenweave.mining.duplicates import Clock, SeenEvents
from scenweave.mining.records import record_of
from scenweave.mining.tracks import Recording
from scenweave.mining.where import Where
from scenweave.schemas.scenario_folder import MINING_REPORT_NAME


@dataclass
class MiningReport:
    """What one ``mine`` run read, found, wrote and skipped."""

    files: dict[str, dict] = field(default_factory=dict)
    written: Counter = field(default_factory=Counter)
    skipped: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    #: events dropped because an earlier file (or the same one) holds them already
    duplicates: list[dict] = field(default_factory=list)
    #: class -> field -> the written records' values (the report draws histograms of them)
    values: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    #: every written record's criticality, with which record it is (``mining.criticality``)
    criticality: list[dict] = field(default_factory=list)
    #: the ``--where`` expression the records were chosen by, and per class how many of the
    #: playable records it left out
    where: str | None = None
    not_matching: Counter = field(default_factory=Counter)
    seconds: float = 0.0

    @property
    def vehicle_hours(self) -> float:
        return sum(f["vehicle_hours"] for f in self.files.values())

    def to_dict(self) -> dict:
        return {
            "files": self.files,
            "records_written": sum(self.written.values()),
            "records_by_class": dict(sorted(self.written.items())),
            "skipped": self.skipped,
            "duplicates": self.duplicates,
            "warnings": self.warnings,
            "values": self.values,
            "criticality": self.criticality,
            **({"where": self.where, "records_matching": sum(self.written.values()),
                "records_not_matching": dict(sorted(self.not_matching.items()))}
               if self.where is not None else {}),
            "vehicle_hours": round(self.vehicle_hours, 4),
            "seconds": round(self.seconds, 3),
        }


def mine_recordings(recordings: Iterable[Recording], out_dir: Path,
                    thresholds: dict[str, dict[str, float]],
                    classes: tuple[str, ...] = (),
                    on_recording: Callable[[Recording], None] | None = None,
                    where: Where | None = None) -> MiningReport:
    """Detect, check and write every event of ``recordings`` (of those ``where`` matches,
    when given); return the report."""
    report = MiningReport(where=where.text if where is not None else None)
    started = time.perf_counter()
    found: dict[str, list[dict]] = {}
    clock, seen = Clock(), SeenEvents()
    for recording in recordings:
        report.warnings += recording.warnings
        road, offset = clock.place(recording)
        events = [e for e in detect(recording, thresholds) if not classes or e.code in classes]
        report.files[recording.source] = _file_entry(recording, events)
        for number, event in enumerate(events):
            earlier = seen.duplicate_of(event, road, offset, recording.source)
            if earlier is not None:
                report.duplicates.append({**_where(event, recording), "same_as_in": earlier})
                continue
            record = _checked_record(event, recording, number, report, thresholds)
            if record is not None:
                seen.written(event, record)  # a repeat in a later file is named in it
            if record is not None and where is not None and not where(record):
                report.not_matching[event.code] += 1
            elif record is not None:
                _note(report, event, record)
                found.setdefault(event.code, []).append(record)
        if on_recording:
            on_recording(recording)
    for code, records in sorted(found.items()):
        folder = "highway" if records[0]["domain"] == "highway" else "urban"
        write_json_atomic(Path(out_dir) / folder / f"{code}.json", records, indent=None)
        report.written[code] += len(records)
    report.seconds = time.perf_counter() - started
    write_json_atomic(Path(out_dir) / MINING_REPORT_NAME, report.to_dict())
    return report


def _checked_record(event: Event, recording: Recording, number: int, report: MiningReport,
                    thresholds: dict[str, dict[str, float]]) -> dict | None:
    """The event's record if it is one ScenWeave can play back, else None and a reason."""
    try:
        if event.refused:
            raise RecordIssue(event.refused, field="event")
        _moving_at_start(event, thresholds["records"]["min_start_speed_ms"])
        record = record_of(event, Path(recording.source), recording.reader, number)
        admit(record)
    except RecordIssue as issue:
        report.skipped.append({**_where(event, recording),
                               "scenario_id": f"{event.code} event {number}",
                               "field": issue.field, "reason": issue.message})
        return None
    return record


def _note(report: MiningReport, event: Event, record: dict) -> None:
    """A written record's values (histograms) and criticality in the report."""
    critical = record.get("criticality") or {}
    values = report.values.setdefault(event.code, {})
    for name, value in (_reported_values(event, record) | critical).items():
        if isinstance(value, int | float):
            values.setdefault(name, []).append(value)
    report.criticality.append({"scenario_id": record.get("scenario_id"), "class": event.code,
                               "file": record["provenance"]["file"], "ego": event.ego,
                               "npc": event.npc, "start_s": event.start_s, **critical})


def _where(event: Event, recording: Recording) -> dict:
    """Which event of which file: class, vehicles and window."""
    return {"file": recording.source, "class": event.code, "ego": event.ego, "npc": event.npc,
            "start_s": event.start_s, "end_s": event.end_s}


def _moving_at_start(event: Event, least_ms: float) -> None:
    if event.adscene is not None:
        return
    for key, values in event.series.items():
        if key.endswith("_speed_ms") and values and (values[0] or 0.0) < least_ms:
            role = key.removesuffix("_speed_ms")
            raise RecordIssue(f"the {role} moves at {values[0] or 0.0:.1f} m/s when the event "
                              f"starts, below records.min_start_speed_ms = {least_ms:g} (the "
                              "thresholds skip stop-and-go events)",
                              field=f"series.{key}")


def _reported_values(event: Event, record: dict) -> dict:
    """What the report draws of an event: a highway record's fields, an urban record's
    speeds and distances."""
    if event.adscene is None:
        return event.fields
    params = extract_params(record)
    return {k: params[k] for k in ("ego_speed_ms", "tfl_ds_m", "brake_time_s",
                                   "drive_distance_m", "duration_s")
            if isinstance(params.get(k), int | float)}


def _file_entry(recording: Recording, events: list[Event]) -> dict:
    seconds = sum(track.duration_s for track in recording.tracks)
    return {"reader": recording.reader, "tracks": len(recording.tracks),
            "vehicle_hours": seconds / 3600.0,
            "events_by_class": dict(sorted(Counter(e.code for e in events).items()))}

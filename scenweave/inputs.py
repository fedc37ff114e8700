"""What ``scenweave run DATA`` reads: raw MOOVE data or canonical records, as params dicts."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from scenweave import maneuvers
from scenweave.ingest import (
    IngestReport,
    Issue,
    admit,
    check_playable,
    extract_with_variants,
    iter_raw_records,
    load_layouts,
    load_records,
)
from scenweave.ingest.issues import IngestError, RecordIssue
from scenweave.mining.where import NothingMatched, parse_where
from scenweave.schemas.params import Params


@dataclass
class InputSelection:
    """Which records to turn into scenarios."""

    classes: tuple[str, ...] = ()
    per_class: int | None = None
    limit: int | None = None
    variants: int = 0
    seed: int = 0
    layout: Path | None = None
    #: ``--where``: only the records this expression matches (``mining.where``), as typed
    where: str | None = None


@dataclass
class LoadedInput:
    """Params to run, in input order, and the problems met while reading the input."""

    params: list[Params] = field(default_factory=list)
    report: IngestReport = field(default_factory=IngestReport)
    kind: str = "raw"
    #: scenario id -> the series a mined record recorded (``scenweave mine``), which the
    #: replay figure draws against the played scenario
    recorded: dict[str, dict] = field(default_factory=dict)
    #: scenario id -> where its mined record was found (its ``scenario_id`` and
    #: ``provenance``), for the event's in-situ scenario (``scenweave.in_situ_records``)
    mined: dict[str, dict] = field(default_factory=dict)


def is_raw(data: Path) -> bool:
    """Raw MOOVE data has .npy files or urban class folders; canonical data has JSON records."""
    if data.is_file():
        return data.suffix == ".npy"
    candidates = [data, data / "highway", data / "urban"]
    if any(any(c.glob("*.npy")) for c in candidates if c.is_dir()):
        return True
    urban = set(maneuvers.codes("urban"))
    return any(p.is_dir() and p.name in urban for c in candidates if c.is_dir()
               for p in c.iterdir())


def load_input(data: Path, selection: InputSelection) -> LoadedInput:
    """Read ``data`` and return the selected params (variants included) and input issues."""
    loaded = LoadedInput(kind="raw" if is_raw(data) else "canonical")
    counts: dict[str | None, int] = {}
    wanted = parse_where(selection.where) if selection.where is not None else None
    looked_at = matched = 0
    for record, file in _records(data, loaded, selection):
        code = record.get("maneuver_class")
        if selection.classes and code not in selection.classes:
            continue
        if wanted is not None:
            looked_at += 1
            if not wanted(record):
                continue
            matched += 1
        if selection.per_class is not None and counts.get(code, 0) >= selection.per_class:
            continue
        try:
            params = _with_variants(record, selection)
        except (RecordIssue, KeyError, TypeError) as err:
            loaded.report.add([_issue(record, file, err)])
            continue
        counts[code] = counts.get(code, 0) + 1
        loaded.params.extend(params)
        if isinstance(record.get("series"), dict):
            loaded.recorded.update((p["scenario_id"], record["series"]) for p in params)
        if isinstance(record.get("provenance"), dict):
            found = {"scenario_id": record.get("scenario_id"), "provenance": record["provenance"]}
            loaded.mined.update((p["scenario_id"], found) for p in params)
        if selection.limit is not None and len(loaded.params) >= selection.limit:
            del loaded.params[selection.limit:]
            break
    if selection.where is not None and not matched:
        raise NothingMatched(selection.where, looked_at)
    return loaded


def _records(data: Path, loaded: LoadedInput,
             selection: InputSelection) -> Iterator[tuple[dict, str]]:
    if loaded.kind == "raw":
        if data.is_file():
            raise IngestError(f"{data}: give the folder that holds the .npy files")
        layouts = load_layouts(selection.layout)
        for item in iter_raw_records(data, loaded.report, layouts, classes=selection.classes):
            yield item.record, item.file
    else:
        for record in load_records(data):
            yield record, str(record.get("source", {}).get("file") or data)


def _with_variants(record: dict, selection: InputSelection) -> list[Params]:
    """The record's params (``ingest.admit``: the rule ingest applies too) and its variants,
    each one a replay can show; else the record is an input issue."""
    made = [admit(record)]
    if selection.variants:
        made += extract_with_variants(record, selection.variants, selection.seed)
    for params in made[1:]:
        check_playable(params)
    return made


def _issue(record: dict, file: str, err: Exception) -> Issue:
    field_name = getattr(err, "field", None) or (str(err.args[0]) if isinstance(err, KeyError)
                                                 else None)
    message = getattr(err, "message", None) or f"cannot extract params: {err}"
    return Issue(file=file, row=record.get("source", {}).get("row_index"), field=field_name,
                 message=f"{record.get('scenario_id', '?')}: {message}")

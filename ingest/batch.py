"""A raw data folder -> canonical record files plus an ingest report.

Output: ``<out>/highway/<CLASS>.json`` and ``<out>/urban/<CODE>.json`` (arrays of records, as
the thesis's converters write them) and ``<out>/ingest_report.json``. Files are processed one
at a time, so memory stays bounded by the largest input file.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from scenweave.files.atomic import write_json_atomic
from scenweave.ingest.admission import admit
from scenweave.ingest.highway import (
    DEFAULT_BINNING,
    FILE_PATTERN,
    HighwayFileResult,
    canonicalize_highway_file,
    iter_highway_files,
)
from scenweave.ingest.issues import IngestError, IngestReport, Issue, RecordIssue, unexpected_issue
from scenweave.ingest.layouts import HighwayLayouts, load_layouts
from scenweave.ingest.urban import canonicalize_urban_file, iter_urban_files
from scenweave.schemas.scenario_folder import INGEST_REPORT_NAME

NO_DATA_MESSAGE = ("no MOOVE data found: expected highway files <CLASS>_BINS_VALUES.npy or urban "
                   "folders <CODE>/<time>.json, here or in highway/ and urban/ (trajectory data "
                   "such as CommonRoad, NGSIM or highD: use scenweave mine)")


@dataclass
class RawRecord:
    """One checked canonical record and where it came from."""

    record: dict
    file: str


def iter_raw_records(raw_dir: Path, report: IngestReport, layouts: HighwayLayouts | None = None,
                     binning: str = DEFAULT_BINNING,
                     on_file: Callable[[Path], None] | None = None,
                     classes: tuple[str, ...] = ()) -> Iterator[RawRecord]:
    """Canonical records of every raw file that ``admit`` takes; problems go into ``report``.
    With ``classes``, only the files of those classes are read (others' problems are not
    the batch's)."""
    raw_dir = Path(raw_dir)
    if not raw_dir.is_dir():
        raise IngestError(f"input folder not found: {raw_dir}")
    layouts = layouts or load_layouts()
    read_before = report.files_read
    for path in iter_highway_files(raw_dir):
        if classes and _file_class(path) not in classes:
            continue
        try:
            result = canonicalize_highway_file(path, layouts, binning)
        except Exception as err:  # noqa: BLE001 - last line of defence: one file, not the batch
            result = HighwayFileResult(None, [], [unexpected_issue(path.name, err)])
        report.files_read += 1
        report.add(result.issues)
        yield from _checked(result.records, path.name, report)
        if on_file:
            on_file(path)
    for path in iter_urban_files(raw_dir):
        if classes and path.parent.name not in classes:
            continue
        record, issues = canonicalize_urban_file(path)
        report.files_read += 1
        report.add(issues)
        yield from _checked([record] if record else [], f"{path.parent.name}/{path.name}", report)
        if on_file:
            on_file(path)
    if report.files_read == read_before:
        report.add([Issue(file=str(raw_dir), severity="warning", message=NO_DATA_MESSAGE)])


def _file_class(path: Path) -> str | None:
    match = FILE_PATTERN.match(path.name)
    return match.group("code") if match else None


def _checked(records: list[dict], file: str, report: IngestReport) -> Iterator[RawRecord]:
    for record in records:
        row = record.get("source", {}).get("row_index")
        try:
            admit(record)
        except RecordIssue as issue:
            report.add([Issue(file=file, row=row, field=issue.field, message=issue.message)])
            continue
        yield RawRecord(record, file)


def ingest_directory(raw_dir: Path, out_dir: Path, layout_path: Path | None = None,
                     binning: str = DEFAULT_BINNING,
                     on_file: Callable[[Path], None] | None = None) -> IngestReport:
    """Canonicalise every raw file under ``raw_dir`` into ``out_dir``; return the report.

    The records ``out_dir`` held before are replaced: a class file this ingest did not write
    (its rows now refused, or its file gone) is removed, so a later ``run`` makes scenarios of
    exactly what this ingest admitted."""
    report = IngestReport()
    layouts = load_layouts(layout_path)
    pending: dict[tuple[str, str], list[dict]] = {}
    for item in iter_raw_records(raw_dir, report, layouts, binning, on_file):
        key = (_folder(item.record), item.record["maneuver_class"])
        if key not in pending:
            # highway classes arrive one file at a time: write the finished ones now
            for done in [k for k in pending if k[0] == "highway"]:
                _write_group(out_dir, done, pending.pop(done), report)
        pending.setdefault(key, []).append(item.record)
    for key in sorted(pending):
        _write_group(out_dir, key, pending[key], report)
    _remove_stale_records(out_dir, report.records_by_class)
    write_json_atomic(out_dir / INGEST_REPORT_NAME, report.to_dict())
    return report


def _remove_stale_records(out_dir: Path, written: dict[str, int]) -> None:
    for folder in ("highway", "urban"):
        for old in Path(out_dir, folder).glob("*.json"):
            if old.stem not in written:
                old.unlink()


def _folder(record: dict) -> str:
    return "highway" if record["domain"] == "highway" else "urban"


def _write_group(out_dir: Path, key: tuple[str, str], records: list[dict],
                 report: IngestReport) -> None:
    folder, code = key
    write_json_atomic(out_dir / folder / f"{code}.json", records, indent=None)
    report.count(code, len(records))

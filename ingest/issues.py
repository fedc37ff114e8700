"""What went wrong with which file, row and field: collected, never raised mid-batch."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from typing import Literal

from scenweave.errors import InputError

Severity = Literal["error", "warning"]


class IngestError(InputError):
    """Root of the exceptions ``ingest`` raises (bad layout file, unreadable input folder)."""


class LayoutError(IngestError):
    """The highway column-layout file is malformed; the message names the field."""


@dataclass(frozen=True)
class Issue:
    """One problem in the input: where it is and what is wrong."""

    file: str
    message: str
    row: int | None = None
    field: str | None = None
    severity: Severity = "error"
    #: how many frames or rows of ``file`` the warning stands for (one line for all of them)
    count: int = 1

    def line(self) -> str:
        """One human line: ``file, row 12, field 'x': message``."""
        where = [self.file]
        if self.row is not None:
            where.append(f"row {self.row}")
        if self.field:
            where.append(f"field '{self.field}'")
        return f"{', '.join(where)}: {self.message}"

    def to_dict(self) -> dict:
        found = asdict(self)
        if self.count == 1:
            del found["count"]
        return found


class RecordIssue(InputError):
    """Raised inside one record's conversion; the batch catches it and records an Issue."""

    def __init__(self, message: str, field: str | None = None, row: int | None = None):
        super().__init__(message)
        self.message = message
        self.field = field
        self.row = row

    def to_issue(self, file: str) -> Issue:
        return Issue(file=file, message=self.message, row=self.row, field=self.field)


def unexpected_issue(file: str, err: Exception) -> Issue:
    """An exception no check foresaw, as an issue naming the file (the batch goes on)."""
    return Issue(file=file, message=f"unexpected {type(err).__name__} while reading the file: "
                                    f"{err}")


@dataclass
class IngestReport:
    """Counts and issues of one ingest run, written as ``ingest_report.json``."""

    files_read: int = 0
    records_written: int = 0
    records_by_class: dict[str, int] = field(default_factory=dict)
    issues: list[Issue] = field(default_factory=list)

    #: where each warning of ``issues`` stands and what it first said, to fold repeats into it
    _warning_at: dict[tuple, tuple[int, str]] = field(default_factory=dict, repr=False)

    @property
    def errors(self) -> list[Issue]:
        return [i for i in self.issues if i.severity == "error"]

    @property
    def warnings(self) -> list[Issue]:
        return [i for i in self.issues if i.severity == "warning"]

    def add(self, issues: Iterable[Issue]) -> None:
        """Add issues; warnings of one file and field (a label read in every frame) are kept
        once, with a count of the frames or rows they stand for."""
        for issue in issues:
            if issue.severity != "warning":
                self.issues.append(issue)
                continue
            key = (issue.file, _field_pattern(issue.field))
            if key not in self._warning_at:
                self._warning_at[key] = (len(self.issues), issue.message)
                self.issues.append(issue)
            else:
                at, first = self._warning_at[key]
                self.issues[at] = _folded(self.issues[at], issue, first)

    def count(self, maneuver_class: str, n: int = 1) -> None:
        self.records_by_class[maneuver_class] = self.records_by_class.get(maneuver_class, 0) + n
        self.records_written += n

    def to_dict(self) -> dict:
        return {
            "files_read": self.files_read,
            "records_written": self.records_written,
            "records_by_class": dict(sorted(self.records_by_class.items())),
            "errors": len(self.errors),
            "warnings": len(self.warnings),
            "issues": [i.to_dict() for i in (*self.errors, *self.warnings)],
        }


def _field_pattern(field_name: str | None) -> str | None:
    """``key_times[12].temporal_climatic.day_period`` -> ``key_times[*]...``: the same field
    of every frame (other positions, such as a way point's, stay apart)."""
    return None if field_name is None else re.sub(r"^key_times\[\d+\]", "key_times[*]",
                                                  field_name)


def _folded(folded: Issue, again: Issue, first: str) -> Issue:
    """One warning standing for both: the field as a pattern, the frames or rows counted
    ("'Day' read as code 1 in 596 frames"; "..., and alike in 595 more frames" when what was
    read differs from frame to frame)."""
    count = folded.count + again.count
    unit = "frames" if (folded.field or "").startswith("key_times[") else "rows"
    uniform = (again.message == first
               and folded.message in (first, f"{first} in {folded.count} {unit}"))
    message = (f"{first} in {count} {unit}" if uniform
               else f"{first}, and alike in {count - 1} more {unit}")
    return dataclasses.replace(folded, field=_field_pattern(folded.field), row=None, count=count,
                               message=message)

"""What went wrong with which file, row and field: collected, never raised mid-batch."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from typing import Literal

Severity = Literal["error", "warning"]


class IngestError(Exception):
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

    def line(self) -> str:
        """One human line: ``file, row 12, field 'x': message``."""
        where = [self.file]
        if self.row is not None:
            where.append(f"row {self.row}")
        if self.field:
            where.append(f"field '{self.field}'")
        return f"{', '.join(where)}: {self.message}"

    def to_dict(self) -> dict:
        return asdict(self)


class RecordIssue(Exception):
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

    @property
    def errors(self) -> list[Issue]:
        return [i for i in self.issues if i.severity == "error"]

    def add(self, issues: Iterable[Issue]) -> None:
        self.issues.extend(issues)

    def count(self, maneuver_class: str, n: int = 1) -> None:
        self.records_by_class[maneuver_class] = self.records_by_class.get(maneuver_class, 0) + n
        self.records_written += n

    def to_dict(self) -> dict:
        return {
            "files_read": self.files_read,
            "records_written": self.records_written,
            "records_by_class": dict(sorted(self.records_by_class.items())),
            "errors": len(self.errors),
            "warnings": len(self.issues) - len(self.errors),
            "issues": [i.to_dict() for i in self.issues],
        }

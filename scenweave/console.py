"""What a batch tells the terminal after its summary line: the problems, counted per kind,
errors first, the first few of each with file, row and field, and where the rest are."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

from scenweave.ingest import Issue
from scenweave.schemas.scenario_folder import SUMMARY_FILE

#: problems shown per kind; the rest are counted
SHOWN = 3


def problem_lines(input_issues: Iterable[dict], outcomes: Iterable[dict] = (),
                  where: str = SUMMARY_FILE, shown: int = SHOWN) -> list[str]:
    """Refused records, failed scenarios, then warnings: a count line each, the first
    ``shown`` of each kind, and "and N more — see ``where``"."""
    issues = list(input_issues)
    errors = [i for i in issues if i.get("severity", "error") == "error"]
    warnings = [i for i in issues if i.get("severity") == "warning"]
    failed = [o for o in outcomes if o.get("status") == "failed"]
    lines: list[str] = []
    if errors:
        lines += counted_lines(f"refused: {refused_records(errors)} records "
                               f"({len(errors)} input errors)",
                       [issue_line(i) for i in errors], where, shown)
    if failed:
        kinds = Counter(t for o in failed for t in o.get("error_taxonomy") or ["unknown"])
        by_kind = ", ".join(f"{kind} {n}" for kind, n in kinds.most_common())
        lines += counted_lines(f"failed: {len(failed)} scenarios ({by_kind})",
                       [_failure(o) for o in failed],
                       where, shown)
    if warnings:
        lines += counted_lines(f"warnings: {len(warnings)} (read, but not in the form expected)",
                       [issue_line(i) for i in warnings], where, shown)
    return lines


def refused_records(issues: Iterable[dict]) -> int:
    """Records the input errors refused: one per file and row (a file-wide error, one)."""
    return len({(i.get("file"), i.get("row")) for i in issues
                if i.get("severity", "error") == "error"})


def _failure(outcome: dict) -> str:
    """``<id>: <error>``, the id once (errors such as NoSpawnFits already name it)."""
    error = outcome.get("error") or "failed"
    return error if outcome["scenario_id"] in error else f"{outcome['scenario_id']}: {error}"


def issue_line(issue: dict) -> str:
    """``file, row 12, field 'x': message`` of an issue as ``summary.json`` holds it."""
    return Issue(**issue).line()


def counted_lines(head: str, items: list[str], where: str, shown: int = SHOWN) -> list[str]:
    """``head``, the first ``shown`` items indented, and how many more are in ``where``."""
    lines = [head, *(f"  {item}" for item in items[:shown])]
    if len(items) > shown:
        lines.append(f"  and {len(items) - shown} more — see {where}")
    return lines

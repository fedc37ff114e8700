"""The numbers and per-class rows the docs state, made from the class definitions.

    .venv/bin/python scripts/doc_tables.py           # rewrite what drifted, say what changed
    .venv/bin/python scripts/doc_tables.py --check   # exit 1 naming each drift, write nothing

Why: the README's counts (classes, reference scripts, the demo's records, the benchmark's
classes) and the first column of docs/scenario-conventions.md's table "What each class puts in
the Story" (which classes each reference script makes) were kept by hand and drifted whenever a
class or a script was added. Here each is a rule computed from ``scenweave.maneuvers`` (the
built-in classes: a plugin's do not change the docs), the demo's defaults and the benchmark's
class list; ``tests/test_doc_tables.py`` runs ``--check``. The prose of each row stays the
author's: only the classes-and-scripts cell is made, and a script without a row gets one that
asks for its prose.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
CONVENTIONS = ROOT / "docs" / "scenario-conventions.md"
#: the header of the conventions' per-class table; its rows run to the first blank line
STORY_TABLE = "| class (script) | events besides `hero_speed_change` |"
NEW_ROW_PROSE = "(to be described: the events this script adds)"


@dataclass(frozen=True)
class Count:
    """A number a doc states: every match of ``pattern`` in ``path`` has ``value()`` in each
    of its groups."""

    path: Path
    pattern: str
    value: Callable[[], int]
    what: str


def builtin_classes() -> list:
    """The built-in manoeuvre classes, by code (a plugin's classes are not in the docs)."""
    from scenweave import maneuvers
    from scenweave.maneuvers.registry import is_builtin

    return [m for m in maneuvers.maneuvers() if is_builtin(m.code)]


def script_count() -> int:
    return len({m.script for m in builtin_classes()})


def class_count() -> int:
    return len(builtin_classes())


def _demo_per_class() -> int:
    from scenweave.commands.demo import demo

    return int(next(p.default for p in demo.params if p.name == "per_class"))


def demo_seeded_records() -> int:
    """The demo's seeded sample records: ``--per-class`` (default) of every class."""
    return _demo_per_class() * class_count()


def demo_records() -> int:
    """... plus the phased car-following rows of each class that has them."""
    from scenweave.commands.demo import PHASED_ROWS

    phased = sum(m.sample_phased is not None for m in builtin_classes())
    return demo_seeded_records() + PHASED_ROWS * phased


def bench_classes() -> int:
    from scenweave.bench import THESIS_CLASSES

    return len(THESIS_CLASSES)


COUNTS = (
    Count(README, r"the (\d+) reference scripts", script_count, "reference scripts"),
    Count(README, r"sample data \(all (\d+) classes\)", class_count, "classes"),
    Count(README, r"MOOVE formats \((\d+) records", demo_seeded_records, "demo's seeded records"),
    Count(README, r"turns all (\d+) records", demo_records, "demo's records"),
    Count(README, r"replay: (\d+)/(\d+) played as recorded", demo_records, "demo's replays"),
    Count(README, r"the (\d+) highway classes of thesis", bench_classes, "benchmark's classes"),
    Count(CONVENTIONS, r"so all (\d+) scripts follow", script_count, "reference scripts"),
)


def fixed_counts(text: str, path: Path) -> tuple[str, list[str]]:
    """``text`` with every count of ``path`` made right, and a line per one that was not."""
    drifts: list[str] = []
    for count in (c for c in COUNTS if c.path == path):
        want = str(count.value())

        def right(match: re.Match[str], count: Count = count, want: str = want) -> str:
            found = match.group(0)
            for group in range(len(match.groups()), 0, -1):
                if match.group(group) != want:
                    drifts.append(f"{path.name}: {count.what} {match.group(group)} -> {want}")
                    start, end = match.span(group)
                    at = match.start(0)
                    found = found[:start - at] + want + found[end - at:]
            return found

        text, found = re.subn(count.pattern, right, text)
        if not found:
            drifts.append(f"{path.name}: no sentence matches {count.pattern!r} ({count.what})")
    return text, drifts


def story_cell(codes: list[str], scripts: list[str]) -> str:
    """The first cell of a per-class row: ``CINF, CINB (`gen_hw_cinf.py`, `gen_hw_cinb.py`)``."""
    return f"{', '.join(codes)} ({', '.join(f'`{s}`' for s in scripts)})"


def fixed_story_table(text: str) -> tuple[str, list[str]]:
    """The conventions' per-class table with each row's classes made from its scripts (in the
    row's script order, each script's classes by code), a row for a script no row names."""
    lines = text.split("\n")
    if STORY_TABLE not in lines:
        return text, [f"{CONVENTIONS.name}: the table {STORY_TABLE!r} is gone"]
    first = lines.index(STORY_TABLE) + 2  # header, separator
    last = next((i for i in range(first, len(lines)) if not lines[i].startswith("|")),
                len(lines))
    by_script: dict[str, list[str]] = {}
    for maneuver in builtin_classes():
        by_script.setdefault(maneuver.script, []).append(maneuver.code)
    drifts: list[str] = []
    rows = [_fixed_row(line, by_script, drifts) for line in lines[first:last]]
    named = {s for line in rows for s in re.findall(r"`(gen_\w+\.py)`", line.split(" | ")[0])}
    for script in sorted(set(by_script) - named):
        drifts.append(f"{CONVENTIONS.name}: no row for {script}")
        rows.append(f"| {story_cell(by_script[script], [script])} | {NEW_ROW_PROSE} |")
    return "\n".join([*lines[:first], *rows, *lines[last:]]), drifts


def _fixed_row(line: str, by_script: dict[str, list[str]], drifts: list[str]) -> str:
    cell, separator, prose = line[2:].partition(" | ")
    scripts = [s for s in re.findall(r"`([\w.]+\.py)`", cell) if s in by_script]
    if not scripts:
        drifts.append(f"{CONVENTIONS.name}: row {cell!r} names no reference script")
        return line
    made = story_cell([code for s in scripts for code in by_script[s]], scripts)
    if made != cell:
        drifts.append(f"{CONVENTIONS.name}: {cell!r} -> {made!r}")
    return f"| {made}{separator}{prose}"


def made_docs() -> dict[Path, tuple[str, list[str]]]:
    """Each doc as the rules make it, with what drifted."""
    readme, readme_drifts = fixed_counts(README.read_text(encoding="utf-8"), README)
    conventions, count_drifts = fixed_counts(CONVENTIONS.read_text(encoding="utf-8"),
                                             CONVENTIONS)
    conventions, row_drifts = fixed_story_table(conventions)
    return {README: (readme, readme_drifts), CONVENTIONS: (conventions, count_drifts + row_drifts)}


def main(argv: list[str]) -> int:
    check = "--check" in argv
    drifted = False
    for path, (text, drifts) in made_docs().items():
        for drift in drifts:
            print(drift)
        drifted |= bool(drifts)
        if drifts and not check:
            path.write_text(text, encoding="utf-8")
    return 1 if drifted and check else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

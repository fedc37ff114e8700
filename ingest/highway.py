"""Highway ``<CLASS>_BINS_VALUES.npy`` files -> canonical records (thesis Appendix B).

Canonicalisation is structural: name the columns, type the cells, keep sentinels as they
are. Cells are checked column by column with NumPy; a bad cell costs its row, named by file,
row and field, and the rest of the file goes on.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenweave import maneuvers
from scenweave.ingest.issues import Issue
from scenweave.ingest.layouts import ClassLayout, Column, HighwayLayouts
from scenweave.ingest.npy import load_npy
from scenweave.maneuvers.free_ride import SLOTS, slot_present

SCHEMA_VERSION = "phase1.v1"
DEFAULT_BINNING = "B0"
FILE_PATTERN = re.compile(r"^(?P<code>[A-Z_]+?)_BINS_VALUES\.npy$")


@dataclass
class HighwayFileResult:
    """What one file gave: its records, the problems found, and how many rows it had."""

    maneuver_class: str | None
    records: list[dict]
    issues: list[Issue]
    rows: int = 0


def class_of_file(path: Path, layouts: HighwayLayouts) -> str:
    """The manoeuvre class a file name announces; ValueError when it names none we know."""
    match = FILE_PATTERN.match(path.name)
    if not match:
        raise ValueError("file name must look like <CLASS>_BINS_VALUES.npy")
    code = match.group("code")
    if code not in layouts.classes:
        raise ValueError(f"unknown class {code!r} (known: {', '.join(sorted(layouts.classes))}; "
                         f"a class of your own is added with ${maneuvers.PLUGINS_ENV})")
    return code


def canonicalize_highway_file(path: Path, layouts: HighwayLayouts,
                              binning: str = DEFAULT_BINNING) -> HighwayFileResult:
    """Read one highway file and return its canonical records and issues (never raises)."""
    name = path.name
    try:
        code = class_of_file(path, layouts)
    except ValueError as err:
        return HighwayFileResult(None, [], [Issue(file=name, message=str(err))])
    layout = layouts.classes[code]
    try:
        array = load_npy(path)
    except Exception as err:  # noqa: BLE001 - any unreadable file is one issue, not a crash
        problem = Issue(file=name, message=f"not a readable .npy: {err}")
        return HighwayFileResult(code, [], [problem])
    shape_problem = _shape_problem(array, layout)
    if shape_problem:
        return HighwayFileResult(code, [], [Issue(file=name, message=shape_problem)],
                                 rows=array.shape[0] if array.ndim else 0)
    columns, issues = _parse_columns(array, layout, name)
    bad_rows = {i.row for i in issues}
    as_lists = [columns[n].tolist() for n in layout.names]  # Python floats/str, once per column
    records = [_record(layout, dict(zip(layout.names, values, strict=True)), row, path.stem,
                       name, binning)
               for row, values in enumerate(zip(*as_lists, strict=True)) if row not in bad_rows]
    return HighwayFileResult(code, records, issues, rows=array.shape[0])


def _shape_problem(array: np.ndarray, layout: ClassLayout) -> str | None:
    expected = len(layout.columns)
    if array.ndim != 2:
        return (f"expected a 2-D array (rows x {expected} columns for {layout.code}), "
                f"got shape {array.shape}")
    if array.shape[0] == 0:
        return "the file has no rows"
    if array.shape[1] != expected:
        return (f"{array.shape[1]} columns, but the {layout.code} layout has {expected} "
                f"({', '.join(layout.names)}); pass --layout to use another layout")
    return None


def _parse_columns(array: np.ndarray, layout: ClassLayout,
                   file: str) -> tuple[dict[str, np.ndarray], list[Issue]]:
    columns: dict[str, np.ndarray] = {}
    issues: list[Issue] = []
    for index, column in enumerate(layout.columns):
        cells = array[:, index]
        if column.kind == "number":
            values, problems = _parse_numbers(cells, column)
        else:
            values, problems = _parse_enum(cells, column)
        columns[column.name] = values
        issues.extend(Issue(file=file, row=row, field=column.name, message=msg)
                      for row, msg in problems)
    return columns, issues


def _parse_numbers(cells: np.ndarray, column: Column) -> tuple[np.ndarray, list[tuple[int, str]]]:
    try:
        values = cells.astype(np.float64)
    except (TypeError, ValueError):
        values = np.array([_to_float(c) for c in cells], dtype=np.float64)
    problems: list[tuple[int, str]] = []
    for row in np.flatnonzero(~np.isfinite(values)):
        cell = cells[row]
        problems.append((int(row), f"not a finite number: {cell!r}"))
    in_range = np.isfinite(values)
    if column.sentinels:
        in_range &= ~np.isin(values, column.sentinels)
    if column.min is not None:
        for row in np.flatnonzero(in_range & (values < column.min)):
            problems.append((int(row), f"{values[row]:g} is below the minimum {column.min:g}"
                                       + (f" {column.unit}" if column.unit else "")))
    if column.max is not None:
        for row in np.flatnonzero(in_range & (values > column.max)):
            problems.append((int(row), f"{values[row]:g} is above the maximum {column.max:g}"
                                       + (f" {column.unit}" if column.unit else "")))
    return values, problems


def _to_float(cell: object) -> float:
    try:
        return float(cell)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return np.nan


def _parse_enum(cells: np.ndarray, column: Column) -> tuple[np.ndarray, list[tuple[int, str]]]:
    # a cell that is no string (a pickled list or array) is never valid; as None it compares
    stripped = np.array([c.strip() if isinstance(c, str) else None for c in cells], dtype=object)
    valid = np.isin(stripped, np.array(column.values, dtype=object))
    problems = [(int(row), f"{cells[row]!r} is not one of {', '.join(column.values)}")
                for row in np.flatnonzero(~valid)]
    return stripped, problems


def _record(layout: ClassLayout, params: dict, row: int, stem: str, file: str,
            binning: str) -> dict:
    has_npc, npc_position = _npc_presence(layout, params)
    return {
        "schema_version": SCHEMA_VERSION,
        "scenario_id": f"{layout.code}_{binning}_{stem}_row{row:06d}",
        "maneuver_class": layout.code,
        "maneuver_tag": layout.tag,
        "domain": "highway",
        "has_npc": has_npc,
        "npc_position": npc_position,
        "binning_version": binning,
        "source": {"file": file, "row_index": row},
        "behavior_type": params.get("behavior_type"),
        "params": params,
        "conventions": layout.conventions,
    }


def _npc_presence(layout: ClassLayout, params: dict) -> tuple[bool, str | None]:
    """Whether the record has an NPC, and where it starts: a signed ``npc_distance_m`` says
    (a cut-in from behind is negative), else the class's position."""
    if layout.maneuver.surrounding_slots:
        sentinels = layout.conventions.get("sentinels", {})
        present = any(slot_present(params, slot, sentinels) for slot in SLOTS)
        return present, layout.npc_position if present else None
    if layout.npc_position is None:
        return False, None
    distance = params.get("npc_distance_m")
    if isinstance(distance, float | int):
        return True, "front" if math.copysign(1.0, distance) > 0 else "behind"
    return True, layout.npc_position


def iter_highway_files(folder: Path) -> Iterator[Path]:
    """The ``.npy`` files directly in ``folder`` or in a ``highway/`` subfolder, sorted."""
    for base in (folder, folder / "highway"):
        if base.is_dir():
            yield from sorted(base.glob("*.npy"))

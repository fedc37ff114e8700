"""What the readers share: header matching, unit constants, vehicle classes, heading from
motion and the natural order of track ids."""

from __future__ import annotations

import csv
import re
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from scenweave.mining.tracks import Floats, Mask, Steps, Track

FOOT_M = 0.3048

#: a file's vehicle class (lower case) -> the ScenWeave family; ``None`` = not a vehicle we keep
VEHICLE_TYPES: dict[str, str | None] = {
    "car": "car", "auto": "car", "taxi": "car", "priorityvehicle": "car",
    "parkedvehicle": "car", "van": "van", "truck": "truck", "bus": "truck",
    "motorcycle": "motorcycle", "motorbike": "motorcycle",
    "pedestrian": None, "bicycle": None, "bike": None,
}

#: below this speed (m/s) a position difference is noise: the heading is held instead
STILL_MPS = 0.5


def header_key(name: str) -> str:
    """``"Vehicle_ID"``, ``" vehicle id "`` and ``"VehicleId"`` all become ``"vehicleid"``."""
    return re.sub(r"[^a-z0-9]", "", name.lower())


def vehicle_type(name: str) -> str | None:
    """The ScenWeave family of a file's class name, ``None`` for a road user we skip; an
    unknown class is taken as a car (most road users of a recording are)."""
    return VEHICLE_TYPES.get(header_key(name), "car")


def skipped_warning(skipped: Counter[str]) -> list[str]:
    """One warning line counting the road users a reader left out, by class."""
    if not skipped:
        return []
    counts = ", ".join(f"{n} {kind}" for kind, n in sorted(skipped.items()))
    return [f"skipped road users that are not vehicles: {counts}"]


def heading_from_motion(x: Floats, y: Floats, t: Floats,
                        still_mps: float = STILL_MPS) -> Floats:
    """Heading (rad) of one vehicle's motion: :func:`segment_headings` for one segment."""
    return segment_headings(x, y, t, np.array([0]), still_mps)


def segment_gradient(v: Floats, t: Floats, starts: Steps) -> Floats:
    """dv/dt within each segment of rows (``starts``: the first row of each, ascending), as
    ``np.gradient`` per segment: central differences inside, one-sided at the ends."""
    n = len(v)
    rows = np.arange(n)
    first, last = np.zeros(n, bool), np.zeros(n, bool)
    first[starts] = True
    last[np.r_[starts[1:] - 1, n - 1]] = True
    lo = np.where(first, rows, rows - 1)
    hi = np.where(last, rows, np.minimum(rows + 1, n - 1))
    span = t[hi] - t[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(span > 0, (v[hi] - v[lo]) / span, 0.0)


def segment_headings(x: Floats, y: Floats, t: Floats, starts: Steps,
                     still_mps: float = STILL_MPS) -> Floats:
    """Heading (rad) of the motion of each segment of rows (one vehicle each); where it stands
    still its last moving heading is held (its first one before it moves); NaN for a
    segment that never moves."""
    n = len(t)
    if n == 0:
        return np.empty(0)
    vx, vy = segment_gradient(x, t, starts), segment_gradient(y, t, starts)
    heading = np.arctan2(vy, vx)
    moving = np.hypot(vx, vy) >= still_mps
    lengths = np.diff(np.r_[starts, n])
    seg_start, seg_end = np.repeat(starts, lengths), np.repeat(np.r_[starts[1:], n], lengths)
    rows = np.arange(n)
    before = np.maximum.accumulate(np.where(moving, rows, -1))
    after = np.minimum.accumulate(np.where(moving, rows, n)[::-1])[::-1]
    use = np.where(before >= seg_start, before, np.where(after < seg_end, after, -1))
    return np.where(use >= 0, heading[np.maximum(use, 0)], np.nan)


Item = TypeVar("Item", bound=np.generic)


def hold_last(values: npt.NDArray[Item], valid: Mask) -> npt.NDArray[Item]:
    """``values`` where ``valid``, elsewhere the last valid value before (the first valid one
    for the steps before it)."""
    idx = np.where(valid, np.arange(len(values)), -1)
    np.maximum.accumulate(idx, out=idx)
    idx[idx < 0] = int(np.argmax(valid))
    return values[idx]


def id_order(track_id: str) -> tuple[str | int, ...]:
    """Sort key putting ``"9"`` before ``"10"`` and ``"10"`` before ``"10-2"``."""
    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", track_id))


def sort_tracks(tracks: Iterable[Track]) -> list[Track]:
    return sorted(tracks, key=lambda track: id_order(track.id))


# --- delimited tables -------------------------------------------------------------------------

MAX_ROW_WARNINGS = 20
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")


def delimiter_of(line: str) -> str | None:
    """A line's separator: comma, semicolon or tab, else blanks (``None``)."""
    for candidate in (",", ";", "\t"):
        if candidate in line:
            return candidate
    return None


def split_line(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return next(csv.reader([line], delimiter=delimiter))


def first_line(path: Path) -> str:
    """The file's first line ('' if it cannot be read): enough to tell a format."""
    try:
        with path.open(encoding="utf-8", errors="replace") as fh:
            return fh.readline()
    except OSError:
        return ""


def header_keys(fields: list[str], aliases: dict[str, str] | None = None) -> list[str] | None:
    """The fields as normalised column names, or ``None`` when they are data (all numbers)."""
    if all(_NUMBER.fullmatch(f.strip()) for f in fields if f.strip()):
        return None
    keys = [header_key(f) for f in fields]
    return [(aliases or {}).get(k, k) for k in keys]


@dataclass
class TableSpec:
    """What a reader wants of a delimited table."""

    #: columns every row must have as a number
    numeric: tuple[str, ...]
    #: columns read as numbers if present
    optional: tuple[str, ...] = ()
    #: columns kept as text (must be present)
    text: tuple[str, ...] = ()
    #: every column the format documents (others are reported as not used)
    known: tuple[str, ...] = ()
    #: other spellings -> the names above
    aliases: dict[str, str] = field(default_factory=dict)
    #: the column order of a headerless file (``None``: a header is required)
    headerless: tuple[str, ...] | None = None


def load_table(path: Path, spec: TableSpec, warnings: list[str]) -> dict[str, np.ndarray]:
    """The wanted columns of ``path``, one value per good row; a row that is short or not
    numeric where it must be is skipped with one warning naming the file and its line (the
    first :data:`MAX_ROW_WARNINGS` of them, then a count). A missing column raises
    ``ValueError``."""
    line = first_line(path)
    delimiter = delimiter_of(line)
    fields = split_line(line, delimiter)
    names = header_keys(fields, spec.aliases)
    header_warnings: list[str] = []
    index = _column_index(names, len(fields), spec, path.name, header_warnings)
    numeric = [n for n in (*spec.numeric, *spec.optional) if n in index]
    if not spec.text:
        try:  # the fast path: numpy parses every row in C
            values = np.loadtxt(path, delimiter=delimiter, skiprows=int(names is not None),
                                usecols=[index[n] for n in numeric], ndmin=2, comments=None,
                                quotechar='"', encoding="utf-8")
        except ValueError:
            pass  # a bad row: the slow path below finds and names it
        else:
            warnings += header_warnings
            return {n: values[:, i] for i, n in enumerate(numeric)}
    return _load_rows(path, spec, warnings)


def _load_rows(path: Path, spec: TableSpec, warnings: list[str]) -> dict[str, np.ndarray]:
    """:func:`load_table` row by row in Python, naming each row it has to skip."""
    with path.open(encoding="utf-8", errors="replace") as fh:
        lines = fh.read().splitlines()
    start = next((i for i, line in enumerate(lines) if line.strip()), len(lines))
    delimiter = delimiter_of(lines[start]) if start < len(lines) else ","
    fields = split_line(lines[start], delimiter) if start < len(lines) else []
    names = header_keys(fields, spec.aliases)
    index = _column_index(names, len(fields), spec, path.name, warnings)
    split = (line.split() for line in lines) if delimiter is None else csv.reader(
        lines, delimiter=delimiter)
    rows = [(no + 1, fields) for no, fields in enumerate(split)
            if no >= start + (names is not None) and "".join(fields).strip()]
    numeric = [n for n in (*spec.numeric, *spec.optional) if n in index]
    bad: list[str] = []
    rows = _complete_rows(rows, max(index.values(), default=0) + 1, path.name, bad)
    values, rows = _parse_numbers(rows, [index[n] for n in numeric], path.name, bad)
    warnings += bad[:MAX_ROW_WARNINGS]
    if len(bad) > MAX_ROW_WARNINGS:
        warnings.append(f"{path.name}: {len(bad) - MAX_ROW_WARNINGS} more bad rows skipped")
    table = {n: values[:, i] for i, n in enumerate(numeric)}
    for n in spec.text:
        table[n] = np.array([fields[index[n]].strip() for _, fields in rows], dtype=str)
    return table


def _column_index(names: list[str] | None, n_fields: int, spec: TableSpec, source: str,
                  warnings: list[str]) -> dict[str, int]:
    """Wanted column -> its index; warns about columns the format does not document."""
    if names is None:
        if spec.headerless is None:
            raise ValueError(f"{source}: no header line")
        names = list(spec.headerless[:n_fields])
    unknown = [n for n in names if n not in spec.known]
    if spec.known and unknown:
        warnings.append(f"{source}: columns not used: {', '.join(unknown)}")
    missing = [n for n in (*spec.numeric, *spec.text) if n not in names]
    if missing:
        raise ValueError(f"{source}: no column {', '.join(missing)}")
    wanted = (*spec.numeric, *spec.optional, *spec.text)
    return {n: names.index(n) for n in wanted if n in names}


def _complete_rows(rows: list[tuple[int, list[str]]], width: int, source: str,
                   bad: list[str]) -> list[tuple[int, list[str]]]:
    kept = []
    for line_no, fields in rows:
        if len(fields) < width:
            bad.append(f"{source}: row {line_no}: {len(fields)} fields, expected {width}")
        else:
            kept.append((line_no, fields))
    return kept


def _parse_numbers(rows: list[tuple[int, list[str]]], columns: list[int], source: str,
                   bad: list[str]) -> tuple[Floats, list[tuple[int, list[str]]]]:
    """The numeric columns of ``rows`` in one vectorised conversion; only when that fails is
    each row tried on its own, to name and drop the bad ones."""
    text = [[fields[i].strip() for i in columns] for _, fields in rows]
    try:
        return np.array(text, dtype=float).reshape(len(rows), len(columns)), rows
    except ValueError:
        pass
    kept, values = [], []
    for (line_no, fields), row in zip(rows, text, strict=True):
        try:
            values.append([float(v) for v in row])
        except ValueError:
            bad.append(f"{source}: row {line_no}: not a number in {', '.join(row)}")
            continue
        kept.append((line_no, fields))
    return np.array(values, dtype=float).reshape(len(kept), len(columns)), kept

"""Highway column layouts: which field each column of a ``<CLASS>_BINS_VALUES.npy`` holds.

Layouts are data (``schemas/highway_layouts.json``), so a user whose files differ passes
their own file with ``--layout`` instead of editing code.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path
from typing import Any

from scenweave import maneuvers
from scenweave.ingest.issues import LayoutError

DEFAULT_LAYOUT_PATH = Path(__file__).resolve().parent.parent / "schemas" / "highway_layouts.json"

@dataclass(frozen=True)
class Column:
    """One column: a number (with optional bounds and sentinels) or one of fixed strings."""

    name: str
    kind: str
    unit: str | None = None
    values: tuple[str, ...] = ()
    min: float | None = None
    max: float | None = None
    sentinels: tuple[float, ...] = ()


@dataclass(frozen=True)
class ClassLayout:
    """The layout of one manoeuvre class's file."""

    code: str
    tag: str
    npc_position: str | None
    columns: tuple[Column, ...]
    relative_speed_sign: int | None = None
    gaps_between: str | None = None
    #: cut-in classes: what the ``direction`` column names (:data:`DIRECTION_MEANINGS`)
    direction_is: str | None = None

    @property
    def maneuver(self) -> maneuvers.Maneuver:
        return maneuvers.get(self.code)

    @cached_property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.columns)

    @cached_property
    def conventions(self) -> dict:
        """What extraction must know of this layout beyond the column names; copied into
        every canonical record (``conventions``) so params follow the layout the file was
        read with: the relative-speed sign (cut classes), where its gaps are measured
        (``gaps_between``) and each column's sentinels."""
        found: dict = {}
        if self.maneuver.relative_speed:
            found["relative_speed_sign"] = self.relative_speed_sign
        if self.gaps_between is not None:
            found["gaps_between"] = self.gaps_between
        if self.direction_is is not None:
            found["direction_is"] = self.direction_is
        sentinels = {c.name: list(c.sentinels) for c in self.columns if c.sentinels}
        if sentinels:
            found["sentinels"] = sentinels
        return found


#: how a layout's gap columns are measured: between the facing bumpers (what a radar on the
#: recording car measures) or between the vehicles' reference points (rear axles)
GAP_CONVENTIONS = ("bumpers", "reference_points")
#: what a cut-in's ``direction`` names: the way the cutter moves (``move``, ScenWeave's
#: default) or the side of the ego it comes from (``from_side``); docs/highway-layouts.md
DIRECTION_MEANINGS = ("move", "from_side")


@dataclass(frozen=True)
class HighwayLayouts:
    """All class layouts of one layout file."""

    version: str
    classes: dict[str, ClassLayout]
    source: str


def load_layouts(path: Path | str | None = None) -> HighwayLayouts:
    """Read and check a layout file (default: the bundled one); LayoutError names the field."""
    path = Path(path) if path else DEFAULT_LAYOUT_PATH
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise LayoutError(f"layout file {path}: cannot read it: {err}") from err
    where = str(path)
    classes = _require(doc, "classes", dict, where)
    layouts = {code: _class_layout(code, spec, f"{where}: classes.{code}")
               for code, spec in classes.items()}
    for maneuver in maneuvers.maneuvers("highway"):  # a plugin class brings its own layout
        if maneuver.code not in layouts and maneuver.layout is not None:
            layouts[maneuver.code] = _class_layout(maneuver.code, dict(maneuver.layout),
                                                   f"manoeuvre {maneuver.code}: layout")
    return HighwayLayouts(version=str(doc.get("layout_version", "custom")), classes=layouts,
                          source=where)


def default_layouts() -> HighwayLayouts:
    """The bundled layouts (for records that carry no ``conventions``), read once per set of
    registered classes."""
    return _default_layouts(tuple(maneuvers.codes("highway")))


@cache
def _default_layouts(known: tuple[str, ...]) -> HighwayLayouts:
    return load_layouts()


def _class_layout(code: str, spec: Any, where: str) -> ClassLayout:
    maneuver = maneuvers.find(code)
    if maneuver is None or maneuver.domain != "highway":
        raise LayoutError(f"{where}: unknown class {code!r} "
                          f"(known: {', '.join(maneuvers.codes('highway'))})")
    if not isinstance(spec, dict):
        raise LayoutError(f"{where}: must be an object")
    columns = tuple(_column(c, f"{where}.columns[{i}]")
                    for i, c in enumerate(_require(spec, "columns", list, where)))
    names = [c.name for c in columns]
    if len(set(names)) != len(names):
        raise LayoutError(f"{where}.columns: duplicate column names")
    missing = [f for f in maneuver.layout_fields if f not in names]
    if missing:
        raise LayoutError(f"{where}.columns: missing required field(s) {', '.join(missing)}")
    sign = spec.get("relative_speed_sign")
    if maneuver.relative_speed and (isinstance(sign, bool) or sign not in (1, -1)):
        raise LayoutError(f"{where}.relative_speed_sign: must be 1 or -1, got {sign!r}")
    gaps_between = spec.get("gaps_between")
    if gaps_between not in (*GAP_CONVENTIONS, None):
        raise LayoutError(f"{where}.gaps_between: must be one of {', '.join(GAP_CONVENTIONS)} "
                          f"or absent, got {gaps_between!r}")
    direction_is = spec.get("direction_is")
    if direction_is is not None and (direction_is not in DIRECTION_MEANINGS
                                     or not maneuver.npc_ends_in_ego_lane):
        raise LayoutError(f"{where}.direction_is: cut-in classes only, one of "
                          f"{', '.join(DIRECTION_MEANINGS)}, got {direction_is!r}")
    return ClassLayout(code=code, tag=_class_fact(spec, "tag", maneuver.tag, where),
                       npc_position=_class_fact(spec, "npc_position", maneuver.npc_position,
                                                where),
                       columns=columns,
                       relative_speed_sign=int(sign) if sign in (1, -1) else None,
                       gaps_between=gaps_between, direction_is=direction_is)


def _class_fact(spec: dict, key: str, known: Any, where: str) -> Any:
    """``tag`` and ``npc_position`` are the class's (its :class:`Maneuver`); a layout may
    repeat them, but not contradict them."""
    if key in spec and spec[key] != known:
        raise LayoutError(f"{where}.{key}: the class's {key} is {known!r} (its manoeuvre "
                          f"definition), the layout says {spec[key]!r}")
    return known


def _column(spec: Any, where: str) -> Column:
    if not isinstance(spec, dict):
        raise LayoutError(f"{where}: must be an object")
    name = _require(spec, "name", str, where)
    kind = _require(spec, "kind", str, where)
    if kind not in ("number", "enum"):
        raise LayoutError(f"{where}.kind: must be 'number' or 'enum', got {kind!r}")
    values = tuple(_require(spec, "values", list, where)) if kind == "enum" else ()
    return Column(name=name, kind=kind, unit=spec.get("unit"), values=values,
                  min=spec.get("min"), max=spec.get("max"),
                  sentinels=tuple(float(s) for s in spec.get("sentinels", ())))


def _require(obj: dict, key: str, kind: type, where: str) -> Any:
    value = obj.get(key)
    if not isinstance(value, kind):
        raise LayoutError(f"{where}.{key}: expected {kind.__name__}, got {type(value).__name__}")
    return value

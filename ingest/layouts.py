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

from scenweave.ingest.issues import LayoutError

DEFAULT_LAYOUT_PATH = Path(__file__).resolve().parent.parent / "schemas" / "highway_layouts.json"

#: the fields extraction needs per class family; a custom layout must keep these names
REQUIRED_FIELDS: dict[str, tuple[str, ...]] = {
    "BRAKE": ("ego_vel_kmh", "lead_vel_kmh", "duration_s", "delta_vel_kmh", "npc_distance_m",
              "brake_intensity", "other_dir_traffic", "lead_vehicle_type"),
    "CUT": ("ego_vel_kmh", "cutter_vel_kmh", "delta_vel_kmh", "duration_s", "npc_distance_m",
            "other_dir_traffic", "direction", "lead_vehicle_type"),
    "LC": ("ego_vel_begin_kmh", "ego_vel_end_kmh", "duration_s", "other_dir_traffic",
           "direction"),
    "FL": ("ego_vel_begin_kmh", "ego_vel_end_kmh", "lead_vel_begin_kmh", "lead_vel_end_kmh",
           "npc_distance_begin_m", "npc_distance_end_m", "lead_dist_traveled_m", "duration_s",
           "other_dir_traffic", "behavior_type", "lead_vehicle_type"),
    "FR": ("ego_vel_begin_kmh", "ego_vel_end_kmh", "ego_dist_traveled_m", "duration_s",
           *(f"{slot}_{what}" for slot in ("center", "right", "left")
             for what in ("posx_begin_m", "posx_end_m", "vel_begin_ms", "vel_end_ms",
                          "vehicle_type"))),
}

FAMILY_OF_CLASS = {
    "BRAKE": "BRAKE", "BR_BK": "BRAKE",
    "CINF": "CUT", "CINB": "CUT", "COUTF": "CUT", "COUTB": "CUT",
    "LCF": "LC", "LCB": "LC", "FLF": "FL", "FLB": "FL", "FRF": "FR", "FRB": "FR",
}


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

    @property
    def family(self) -> str:
        return FAMILY_OF_CLASS[self.code]

    @cached_property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.columns)

    @cached_property
    def column_by_name(self) -> dict[str, Column]:
        return {c.name: c for c in self.columns}

    @cached_property
    def conventions(self) -> dict:
        """What extraction must know of this layout beyond the column names; copied into
        every canonical record (``conventions``) so params follow the layout the file was
        read with: the relative-speed sign (cut classes), where its gaps are measured
        (``gaps_between``) and each column's sentinels."""
        found: dict = {}
        if self.family == "CUT":
            found["relative_speed_sign"] = self.relative_speed_sign
        if self.gaps_between is not None:
            found["gaps_between"] = self.gaps_between
        sentinels = {c.name: list(c.sentinels) for c in self.columns if c.sentinels}
        if sentinels:
            found["sentinels"] = sentinels
        return found


#: how a layout's gap columns are measured: between the facing bumpers (what a radar on the
#: recording car measures) or between the vehicles' reference points (rear axles)
GAP_CONVENTIONS = ("bumpers", "reference_points")


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
    return HighwayLayouts(version=str(doc.get("layout_version", "custom")), classes=layouts,
                          source=where)


@cache
def default_layouts() -> HighwayLayouts:
    """The bundled layouts, read once (for records that carry no ``conventions``)."""
    return load_layouts()


def _class_layout(code: str, spec: Any, where: str) -> ClassLayout:
    if code not in FAMILY_OF_CLASS:
        raise LayoutError(f"{where}: unknown class {code!r} (known: {', '.join(FAMILY_OF_CLASS)})")
    if not isinstance(spec, dict):
        raise LayoutError(f"{where}: must be an object")
    columns = tuple(_column(c, f"{where}.columns[{i}]")
                    for i, c in enumerate(_require(spec, "columns", list, where)))
    names = [c.name for c in columns]
    if len(set(names)) != len(names):
        raise LayoutError(f"{where}.columns: duplicate column names")
    missing = [f for f in REQUIRED_FIELDS[FAMILY_OF_CLASS[code]] if f not in names]
    if missing:
        raise LayoutError(f"{where}.columns: missing required field(s) {', '.join(missing)}")
    sign = spec.get("relative_speed_sign")
    if FAMILY_OF_CLASS[code] == "CUT" and (isinstance(sign, bool) or sign not in (1, -1)):
        raise LayoutError(f"{where}.relative_speed_sign: must be 1 or -1, got {sign!r}")
    npc_position = spec.get("npc_position")
    if npc_position not in ("front", "behind", None):
        raise LayoutError(f"{where}.npc_position: must be 'front', 'behind' or null")
    gaps_between = spec.get("gaps_between")
    if gaps_between not in (*GAP_CONVENTIONS, None):
        raise LayoutError(f"{where}.gaps_between: must be one of {', '.join(GAP_CONVENTIONS)} "
                          f"or absent, got {gaps_between!r}")
    return ClassLayout(code=code, tag=str(_require(spec, "tag", str, where)),
                       npc_position=npc_position, columns=columns,
                       relative_speed_sign=int(sign) if sign in (1, -1) else None,
                       gaps_between=gaps_between)


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

"""Free-ride (FRF/FRB) surrounding-vehicle slots and their 'absent' sentinels.

The sentinels are the layout's (``ClassLayout.conventions["sentinels"]``: column name ->
values that mean 'no vehicle'), so canonicalisation (``has_npc``) and extraction (the
``slot_*`` params) decide presence with this one function and the same values.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

SLOTS = ("center", "right", "left")
Sentinels = Mapping[str, Sequence[float]]


def is_sentinel(params: Mapping, field: str, sentinels: Sentinels) -> bool:
    """The value of ``field`` is one of the layout's 'absent' markers for that column."""
    return params[field] in sentinels.get(field, ())


def slot_present(params: Mapping, slot: str, sentinels: Sentinels) -> bool:
    """A slot holds a vehicle unless its start position or start speed is a sentinel
    (or its vehicle type says ``None``)."""
    if is_sentinel(params, f"{slot}_posx_begin_m", sentinels):
        return False
    if is_sentinel(params, f"{slot}_vel_begin_ms", sentinels):
        return False
    return params.get(f"{slot}_vehicle_type") != "None"


def slot_params(params: Mapping, slot: str, sign: float, sentinels: Sentinels) -> dict:
    """The ``<slot>_*`` params of one slot: SI values, distances signed ``sign`` (+1 ahead,
    -1 behind); an absent slot gives present false, 0.0 and None. A present vehicle whose end
    value is a sentinel (it left the sensor's range) keeps its start value."""
    if not slot_present(params, slot, sentinels):
        return {f"{slot}_present": False, f"{slot}_speed_ms": 0.0, f"{slot}_end_speed_ms": 0.0,
                f"{slot}_distance_m": 0.0, f"{slot}_end_distance_m": 0.0,
                f"{slot}_vehicle_type": None}

    def end_or_start(what: str) -> float:
        end = f"{slot}_{what}_end_{'m' if what == 'posx' else 'ms'}"
        start = end.replace("_end_", "_begin_")
        return params[start] if is_sentinel(params, end, sentinels) else params[end]

    return {
        f"{slot}_present": True,
        f"{slot}_speed_ms": params[f"{slot}_vel_begin_ms"],
        f"{slot}_end_speed_ms": end_or_start("vel"),
        f"{slot}_distance_m": sign * abs(params[f"{slot}_posx_begin_m"]),
        f"{slot}_end_distance_m": sign * abs(end_or_start("posx")),
        f"{slot}_vehicle_type": str(params[f"{slot}_vehicle_type"]).lower(),
    }

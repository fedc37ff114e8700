"""Free-ride (FRF/FRB) surrounding-vehicle slots and their 'absent' sentinels."""

from __future__ import annotations

SLOTS = ("center", "right", "left")
POSITION_SENTINELS = (-1.0,)
SPEED_SENTINELS = (-3.6, -1.0)


def slot_present(params: dict, slot: str,
                 position_sentinels: tuple[float, ...] = POSITION_SENTINELS,
                 speed_sentinels: tuple[float, ...] = SPEED_SENTINELS) -> bool:
    """A slot holds a vehicle unless its start position or start speed is a sentinel."""
    if params[f"{slot}_posx_begin_m"] in position_sentinels:
        return False
    if params[f"{slot}_vel_begin_ms"] in speed_sentinels:
        return False
    return params.get(f"{slot}_vehicle_type") != "None"

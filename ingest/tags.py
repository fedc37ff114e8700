"""Manoeuvre class codes and the corpus tags they map to (docs/params.md)."""

from __future__ import annotations

URBAN_TAGS = {
    "U1_1": "in_lane_driving",
    "U4_1": "stop_at_tfl_red",
    "U4_2": "pass_tfl_green_or_orange",
    "U4_3": "straight_tfl_green",
    "U4_4": "turn_right_at_tfl_green",
}

URBAN_NAMES = {
    "U1_1": "In-lane driving",
    "U4_1": "Ego stop at traffic light",
    "U4_2": "Ego pass traffic light",
    "U4_3": "Ego straight through green traffic light",
    "U4_4": "Ego right turn at green traffic light",
}

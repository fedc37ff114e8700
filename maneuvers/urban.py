"""Urban classes (ADScene JSON records): in-lane driving and the ego at a traffic light.

Extraction is common to all of them (``ingest.extract``); a class differs in the light the ego
meets, whether it stops at the line, and its movement through the junction.
"""

from __future__ import annotations

from scenweave.maneuvers.maneuver import Maneuver

MANEUVERS = (
    Maneuver(code="U1_1", tag="in_lane_driving", domain="urban", name="In-lane driving",
             script="gen_ur_in_lane_driving.py", lead_allowed=True),
    Maneuver(code="U4_1", tag="stop_at_tfl_red", domain="urban",
             name="Ego stop at traffic light", script="gen_ur_stop_at_tfl_red.py",
             light="red", stops_at_line=True, verb="stops before"),
    Maneuver(code="U4_2", tag="pass_tfl_green_or_orange", domain="urban",
             name="Ego pass traffic light", script="gen_ur_pass_tfl_green_or_orange.py",
             light="green_or_orange", verb="passes", lead_allowed=True),
    Maneuver(code="U4_3", tag="straight_tfl_green", domain="urban",
             name="Ego straight through green traffic light",
             script="gen_ur_straight_tfl_green.py", light="green",
             verb="drives straight through", lead_allowed=True),
    Maneuver(code="U4_4", tag="turn_right_at_tfl_green", domain="urban",
             name="Ego right turn at green traffic light",
             script="gen_ur_turn_right_at_tfl_green.py", light="green", turn="right",
             verb="turns right at"),
)

"""Highway cut-out in front (COUTF): the car ahead in my lane moves out to the next lane.

The ego follows a vehicle in its own lane. At maneuver_start_s, when it is npc_distance_m
ahead, that vehicle leaves the ego's lane, changing lanes toward lane_change_direction
within duration_s and clearing the road ahead, its speed going from npc_speed_ms to
npc_end_speed_ms. With the lane in front now free, the ego speeds up slightly to
ego_end_speed_ms.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    highway_npc,
    lane_position,
    make_scenario,
    npc_lane_change_story,
    write_scenario,
)

TAG = "cut_out_front"


def generate(params: dict, out_path: str) -> Path:
    """Build the cut-out-in-front scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    leaver = highway_npc(params)
    events = npc_lane_change_story(params)
    scenario = make_scenario(params, TAG, actors=[ego, leaver], events=events)
    return write_scenario(scenario, out_path)

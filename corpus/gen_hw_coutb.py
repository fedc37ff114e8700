"""Highway cut-out behind (COUTB): the car tailgating the ego pulls out of its lane.

A vehicle drives behind the ego in the same lane (npc_distance_m is negative). At
maneuver_start_s, when it is that far behind, this follower pulls out, changing lanes toward
lane_change_direction within duration_s and leaving the ego's lane from behind, while its
speed goes from npc_speed_ms to npc_end_speed_ms. The ego keeps or changes its speed as
recorded.
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

TAG = "cut_out_behind"


def generate(params: dict, out_path: str) -> Path:
    """Build the cut-out-behind scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    follower = highway_npc(params)
    events = npc_lane_change_story(params)
    scenario = make_scenario(params, TAG, actors=[ego, follower], events=events)
    return write_scenario(scenario, out_path)

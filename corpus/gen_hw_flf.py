"""Highway car following (FLF): the ego follows a slower or faster lead car in its lane.

The ego drives behind a lead vehicle in the same lane, keeping a following distance on the
motorway; at maneuver_start_s the lead is npc_distance_m ahead. From then on, over
duration_s, the lead's speed goes from npc_speed_ms to npc_end_speed_ms and the ego's from
ego_speed_ms to ego_end_speed_ms, so the gap to the car in front opens or closes as recorded.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    following_story,
    hero,
    highway_npc,
    lane_position,
    make_scenario,
    write_scenario,
)

TAG = "follow_front"


def generate(params: dict, out_path: str) -> Path:
    """Build the following-a-lead scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    lead = highway_npc(params)
    events = following_story(params)
    scenario = make_scenario(params, TAG, actors=[ego, lead], events=events)
    return write_scenario(scenario, out_path)

"""Highway cut-in in front (CINF): a car from the next lane cuts into my lane just ahead.

A vehicle drives in the adjacent lane. At maneuver_start_s, when it is npc_distance_m
ahead of the ego, it merges into the ego's lane in front of it, changing lanes toward
lane_change_direction within duration_s and squeezing into the gap ahead of the ego, while
its speed goes from npc_speed_ms to npc_end_speed_ms. The ego keeps or changes its speed as
recorded; when the cutter ends up slower than that, the ego reacts a moment after the cut-in
starts and slows to the cutter's end speed, keeping its distance instead of running into it.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_reacts_to_cut_in,
    highway_npc,
    lane_position,
    make_scenario,
    npc_lane_change_story,
    write_scenario,
)

TAG = "cut_in_front"


def generate(params: dict, out_path: str) -> Path:
    """Build the cut-in-in-front scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    cutter = highway_npc(params)
    events = npc_lane_change_story(params, hero_reacts_to_cut_in(params))
    scenario = make_scenario(params, TAG, actors=[ego, cutter], events=events)
    return write_scenario(scenario, out_path)

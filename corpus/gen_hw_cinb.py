"""Highway cut-in behind (CINB): a car from the next lane merges into my lane behind me.

A vehicle drives in the adjacent lane behind the ego (npc_distance_m is negative). At
maneuver_start_s, when it is that far behind, it merges into the ego's lane behind the ego,
changing lanes toward lane_change_direction within duration_s, and then follows the ego
closely; its speed goes from npc_speed_ms to npc_end_speed_ms. The ego stays in front and
keeps or changes its speed as recorded; once the record ends, the merger keeps its distance.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    highway_npc,
    keep_distance_after_record,
    lane_position,
    make_scenario,
    npc_lane_change_story,
    write_scenario,
)

TAG = "cut_in_behind"


def generate(params: dict, out_path: str) -> Path:
    """Build the cut-in-behind scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    merger = highway_npc(params)
    events = [*npc_lane_change_story(params), *keep_distance_after_record(params)]
    scenario = make_scenario(params, TAG, actors=[ego, merger], events=events)
    return write_scenario(scenario, out_path)

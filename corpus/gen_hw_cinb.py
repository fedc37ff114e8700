"""Highway cut-in from behind (CINB): a faster car overtakes the ego and cuts in.

A vehicle in the adjacent lane starts behind the ego (npc_distance_m is negative), passes
it and, at maneuver_start_s, swerves into the ego's lane toward lane_change_direction
within duration_s, ending up right in front of the ego after the overtake; its speed goes
from npc_speed_ms to npc_end_speed_ms. The ego keeps or changes its speed as recorded.
"""

from pathlib import Path

from corpus.corpus_utils import (
    hero,
    hero_speed_profile,
    highway_npc,
    lane_position,
    make_scenario,
    npc_lane_change,
    npc_speed_profile,
    write_scenario,
)

TAG = "cut_in_behind"


def generate(params: dict, out_path: str) -> Path:
    """Build the cut-in-from-behind scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    overtaker = highway_npc(params)
    events = [hero_speed_profile(params), npc_lane_change(params), npc_speed_profile(params)]
    scenario = make_scenario(params, TAG, actors=[ego, overtaker], events=events)
    return write_scenario(scenario, out_path)

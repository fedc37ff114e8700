"""Highway hard braking (BRAKE, BR_BK): the lead car ahead of the ego brakes hard.

The ego drives on a multi-lane highway behind a lead vehicle in its own lane,
npc_distance_m ahead. At maneuver_start_s the lead slams on the brakes and decelerates from
npc_speed_ms to npc_end_speed_ms within duration_s (an emergency stop or sharp slow-down in
front of the ego), while the ego keeps or changes its speed as recorded.
"""

from pathlib import Path

from corpus.corpus_utils import (
    hero,
    hero_speed_profile,
    highway_npc,
    lane_position,
    make_scenario,
    npc_speed_profile,
    write_scenario,
)

TAG = "brake"


def generate(params: dict, out_path: str) -> Path:
    """Build the braking scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    lead = highway_npc(params)
    events = [hero_speed_profile(params), npc_speed_profile(params)]
    scenario = make_scenario(params, TAG, actors=[ego, lead], events=events)
    return write_scenario(scenario, out_path)

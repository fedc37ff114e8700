"""Highway hard braking (BRAKE, BR_BK): the lead car ahead of the ego brakes hard.

The ego drives on a multi-lane highway behind a lead vehicle in its own lane. At
maneuver_start_s, when the lead is npc_distance_m ahead, it slams on the brakes and
decelerates from npc_speed_ms to npc_end_speed_ms within duration_s (an emergency stop or
sharp slow-down in front of the ego). The ego reacts a moment later and slows down to the
lead's end speed, keeping its distance instead of running into the lead.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_reacts_to_braking_lead,
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
    events = [npc_speed_profile(params), hero_reacts_to_braking_lead(params)]
    scenario = make_scenario(params, TAG, actors=[ego, lead], events=events)
    return write_scenario(scenario, out_path)

"""Highway lead speeding away (ACCEL): the lead ahead of the ego accelerates.

The ego drives behind a lead vehicle in its own lane. At maneuver_start_s, when the lead is
npc_distance_m ahead, it speeds up from npc_speed_ms to npc_end_speed_ms within duration_s;
the ego keeps its speed (ego_end_speed_ms).
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_speed_profile,
    highway_npc,
    lane_position,
    make_scenario,
    npc_speed_profile,
    write_scenario,
)

TAG = "lead_accelerates"


def generate(params: dict, out_path: str) -> Path:
    """Build the scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    lead = highway_npc(params)
    events = [npc_speed_profile(params), hero_speed_profile(params)]
    scenario = make_scenario(params, TAG, actors=[ego, lead], events=events)
    return write_scenario(scenario, out_path)

"""Highway followed from behind (FLB): a vehicle follows the ego closely in its lane.

Another vehicle drives behind the ego in the same lane, a follower in the ego's mirror; at
maneuver_start_s it is npc_distance_m (negative) behind. From then on, over duration_s, the
follower's speed goes from npc_speed_ms to npc_end_speed_ms and the ego's from ego_speed_ms
to ego_end_speed_ms, so the follower closes in or falls back as recorded.
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

TAG = "follow_behind"


def generate(params: dict, out_path: str) -> Path:
    """Build the followed-from-behind scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    follower = highway_npc(params)
    events = following_story(params)
    scenario = make_scenario(params, TAG, actors=[ego, follower], events=events)
    return write_scenario(scenario, out_path)

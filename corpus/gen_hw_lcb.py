"""Highway ego lane change ahead of traffic behind (LCB): I pull out in front of cars coming up.

The ego itself changes lanes on a multi-lane highway: at maneuver_start_s it moves one lane
toward lane_change_direction (left or right) within duration_s, pulling out into the
adjacent lane in front of the traffic approaching from behind there, and its speed goes from
ego_speed_ms to ego_end_speed_ms. No scripted vehicle takes part.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    ego_lane_change_story,
    hero,
    lane_position,
    make_scenario,
    write_scenario,
)

TAG = "lane_change_behind"


def generate(params: dict, out_path: str) -> Path:
    """Build the ego lane-change scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    events = ego_lane_change_story(params)
    scenario = make_scenario(params, TAG, actors=[ego], events=events)
    return write_scenario(scenario, out_path)

"""Highway free ride with traffic ahead (FRF): the ego cruises with cars in front in several lanes.

The ego cruises freely on a multi-lane highway with surrounding traffic ahead: up to three
vehicles in front of it, one in the ego lane (center), one in the right lane and one in the
left lane, each present only when the record saw it. From maneuver_start_s, over
duration_s, every vehicle goes from its start speed to its end speed, and so does the ego.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    free_ride_traffic,
    hero,
    hero_speed_profile,
    lane_position,
    make_scenario,
    write_scenario,
)

TAG = "free_ride_front"


def generate(params: dict, out_path: str) -> Path:
    """Build the free-ride-with-traffic-ahead scenario and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    traffic, traffic_events = free_ride_traffic(params)
    events = [hero_speed_profile(params), *traffic_events]
    scenario = make_scenario(params, TAG, actors=[ego, *traffic], events=events)
    return write_scenario(scenario, out_path)

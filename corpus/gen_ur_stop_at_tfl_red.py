"""Urban stop at a red traffic light (U4_1): the light turns red and the ego brakes to a halt.

The ego approaches a signalised intersection at init_speed_ms while the light ahead is
green (yellow already when the ego must brake at once). The light turns yellow, the ego
brakes a moment later and comes to rest just before the stop line
(spawn_stop_line_distance_m ahead of its start), its speed falling to 0 within
brake_time_s; the light is red a few seconds after it turned yellow. A lead vehicle drives
ahead and an oncoming car comes the other way when the record had them.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_stops_at_line,
    lead_keeps_ahead,
    make_scenario,
    red_light_for_stop,
    urban_traffic,
    world_position,
    write_scenario,
)

TAG = "stop_at_tfl_red"


def generate(params: dict, out_path: str) -> Path:
    """Build the stop-at-red-light scenario and write it to ``out_path``."""
    ego = hero(world_position(params, "ego"), params["ego_speed_ms"])
    events = [hero_stops_at_line(params), *red_light_for_stop(params)]
    scenario = make_scenario(params, TAG, actors=[ego, *urban_traffic(params)],
                             events=[*events, *lead_keeps_ahead(params, ego_stops_at_line=True)])
    return write_scenario(scenario, out_path)

"""Urban straight crossing at a green light (U4_3): the ego goes straight across the junction.

The ego approaches a signalised intersection at init_speed_ms while the traffic light is
green and goes straight on through the crossing, its speed going to final_speed_ms over
duration_s. A lead vehicle drives ahead and an oncoming car comes
the other way when the record had them.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_speed_profile,
    lead_keeps_ahead,
    make_scenario,
    traffic_light,
    urban_traffic,
    world_position,
    write_scenario,
)

TAG = "straight_tfl_green"


def generate(params: dict, out_path: str) -> Path:
    """Build the straight-on-green scenario and write it to ``out_path``."""
    ego = hero(world_position(params, "ego"), params["ego_speed_ms"])
    events = [hero_speed_profile(params), traffic_light(params, "initial", "green", 0.0)]
    scenario = make_scenario(params, TAG, actors=[ego, *urban_traffic(params)],
                             events=[*events, *lead_keeps_ahead(params)])
    return write_scenario(scenario, out_path)

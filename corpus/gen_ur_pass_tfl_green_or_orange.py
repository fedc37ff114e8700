"""Urban pass at a green or amber light (U4_2): the ego crosses the junction without stopping.

The ego approaches a signalised intersection at init_speed_ms and crosses it, its speed
going to final_speed_ms over duration_s. The light is green; when the record saw it orange
(amber, tfl_state), it turns yellow as the ego is 5 m before the stop line
(spawn_stop_line_distance_m ahead of its start), so the ego passes on orange, and red a few
seconds later. A lead vehicle drives ahead and an oncoming car comes
the other way when the record had them.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_speed_profile,
    lead_keeps_ahead,
    make_scenario,
    orange_light_for_pass,
    traffic_light,
    urban_traffic,
    world_position,
    write_scenario,
)

TAG = "pass_tfl_green_or_orange"


def generate(params: dict, out_path: str) -> Path:
    """Build the pass-on-green-or-orange scenario and write it to ``out_path``."""
    ego = hero(world_position(params, "ego"), params["ego_speed_ms"])
    events = [hero_speed_profile(params), traffic_light(params, "initial", "green", 0.0)]
    if params["tfl_state"] == "orange":
        events += orange_light_for_pass(params)
    scenario = make_scenario(params, TAG, actors=[ego, *urban_traffic(params)],
                             events=[*events, *lead_keeps_ahead(params)])
    return write_scenario(scenario, out_path)

"""Urban in-lane driving (U1_1): the ego drives along a city street, staying in its lane.

The ego follows its lane through town, with no traffic light involved, maybe behind another
car. It starts at init_speed_ms and its speed goes to final_speed_ms over duration_s. When
the record had a lead vehicle, that vehicle drives lead_distance_m ahead of the ego at
lead_speed_ms; an oncoming car of the record comes the other way at oncoming_speed_ms.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    hero,
    hero_speed_profile,
    lead_keeps_ahead,
    make_scenario,
    urban_traffic,
    world_position,
    write_scenario,
)

TAG = "in_lane_driving"


def generate(params: dict, out_path: str) -> Path:
    """Build the urban in-lane driving scenario and write it to ``out_path``."""
    ego = hero(world_position(params, "ego"), params["ego_speed_ms"])
    events = [hero_speed_profile(params)]
    scenario = make_scenario(params, TAG, actors=[ego, *urban_traffic(params)],
                             events=[*events, *lead_keeps_ahead(params)])
    return write_scenario(scenario, out_path)

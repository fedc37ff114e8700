"""Urban stop at a red traffic light (U4_1): the light turns red and the ego brakes to a halt.

The ego approaches a signalised intersection at init_speed_ms. The traffic light ahead is
green, turns yellow after yellow_delay_s (when the ego is about 5 m before it) and red a
few seconds later. The ego brakes and waits at the stop line: its speed falls to 0 within
brake_time_s. A lead vehicle drives ahead when the record had one.
"""

from pathlib import Path

from corpus.corpus_utils import (
    HERO,
    hero,
    light_turns_red,
    make_scenario,
    speed_change,
    traffic_light,
    urban_lead,
    world_position,
    write_scenario,
)

TAG = "stop_at_tfl_red"


def generate(params: dict, out_path: str) -> Path:
    """Build the stop-at-red-light scenario and write it to ``out_path``."""
    ego = hero(world_position(params, "ego"), params["ego_speed_ms"])
    events = [
        speed_change(HERO, 0.0, params["brake_time_s"], params["maneuver_start_s"]),
        traffic_light(params, "initial", "green", 0.0),
        *light_turns_red(params),
    ]
    scenario = make_scenario(params, TAG, actors=[ego, *urban_lead(params)], events=events)
    return write_scenario(scenario, out_path)

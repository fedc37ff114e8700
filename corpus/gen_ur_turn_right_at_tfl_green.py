"""Urban right turn at a green light (U4_4): the ego turns right at the signalised intersection.

The ego approaches a signalised intersection at init_speed_ms while the traffic light is
green and turns right into the crossing road: it is routed to turn_exit, 10 m into the lane
the junction's right movement leads to (found on the map by the spawn stage), its speed going
to final_speed_ms over duration_s. A lead vehicle drives ahead and an oncoming car comes
the other way when the record had them.
"""

from pathlib import Path

from scenweave.scenario_lib.builder import (
    HERO,
    drive_to,
    hero,
    hero_speed_profile,
    lead_keeps_ahead,
    make_scenario,
    right_turn_target,
    traffic_light,
    urban_traffic,
    world_position,
    write_scenario,
)

TAG = "turn_right_at_tfl_green"


def generate(params: dict, out_path: str) -> Path:
    """Build the right-turn-on-green scenario and write it to ``out_path``."""
    ego = hero(world_position(params, "ego"), params["ego_speed_ms"])
    # the route first: players such as esmini count AcquirePositionAction as a longitudinal
    # action, so one started after the speed change in the same step would end it
    events = [
        drive_to(HERO, "hero_turn_right", right_turn_target(params), params["maneuver_start_s"]),
        hero_speed_profile(params),
        traffic_light(params, "initial", "green", 0.0),
    ]
    scenario = make_scenario(params, TAG, actors=[ego, *urban_traffic(params)],
                             events=[*events, *lead_keeps_ahead(params)])
    return write_scenario(scenario, out_path)

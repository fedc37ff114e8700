"""Highway lane change of the ego in front of the traffic behind in the neighbouring lane (LCB).

The ego drives on a multi-lane highway and, at maneuver_start_s, changes one lane toward
lane_change_direction (left or right) within duration_s, pulling out into the adjacent lane
ahead of whatever follows there, while its speed goes from ego_speed_ms to
ego_end_speed_ms. No scripted vehicle takes part.
"""

from corpus.corpus_utils import (
    hero,
    hero_lane_change,
    hero_speed_profile,
    lane_position,
    make_scenario,
    write_scenario,
)

TAG = "lane_change_behind"


def generate(params, out_path):
    """Build the ego lane-change scenario from ``params`` and write it to ``out_path``."""
    ego = hero(lane_position(params, "ego"), params["ego_speed_ms"])
    events = [hero_lane_change(params), hero_speed_profile(params)]
    scenario = make_scenario(params, TAG, actors=[ego], events=events)
    return write_scenario(scenario, out_path)

"""How a replay runs: time step, wall-clock limit, how long past the scenario's end, the map."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ReplaySettings:
    """Runtime settings of the player (``scenweave replay`` / ``run`` flags)."""

    #: the fixed simulation step (s), esmini's --fixed_timestep
    time_step_s: float = 0.05
    #: the child process playing one scenario is killed after this long (s)
    wall_time_s: float = 30.0
    #: how long a scenario plays when its file states no stop time (s)
    default_duration_s: float = 60.0
    #: play on a copy of the map cut to the roads the scenario reaches (``player.maps``); a
    #: replay whose entities leave them is played again on the whole map
    cut_map: bool = True

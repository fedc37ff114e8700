"""Playing scenarios headless in esmini and recording what happened.

Public API:
- ``replay_file(xosc_path, map_path, settings)`` -> ``Playback``: the scenario translated for
  esmini in a temporary copy (``player.translate``), played in a child process with a time
  limit (``player.engine``); never raises for a problem of the scenario (``engine_error``);
- ``find_esmini()`` -> ``EsminiInstall`` (library, version, where it was found) or
  ``PlayerUnavailable``; ``player_status()`` for ``scenweave doctor``;
- ``Playback`` (``replay.json``), ``ReplaySettings``; errors under ``PlayerError``.
Judging a playback against the record lives with the other checks (``judge.replay``).
"""

from __future__ import annotations

from scenweave.player.errors import PlayerError, PlayerUnavailable
from scenweave.player.locate import EsminiInstall, find_esmini
from scenweave.player.playback import Box, Playback, StoryboardChange
from scenweave.player.replay import player_status, replay_file, scenario_duration_s
from scenweave.player.settings import ReplaySettings
from scenweave.player.translate import TranslationError

__all__ = ["Box", "EsminiInstall", "Playback", "PlayerError", "PlayerUnavailable",
           "ReplaySettings", "StoryboardChange", "TranslationError", "find_esmini",
           "player_status", "replay_file", "scenario_duration_s"]

"""Imported by the player's fork server only: loads esmini's library once, before any child
is forked, so that each replay's child starts with it in memory (saves the dlopen per replay)."""

from contextlib import suppress

from player.engine import preload
from player.errors import PlayerUnavailable

with suppress(PlayerUnavailable):  # play_file raises it in the caller, with what was tried
    preload()

"""The player's exceptions: one root, each message naming the setting to change."""

from __future__ import annotations

from scenweave.errors import InfrastructureError


class PlayerError(InfrastructureError):
    """Root of every failure of the player itself (not of a scenario it plays)."""


class PlayerUnavailable(PlayerError):
    """No esmini library could be found or loaded (set ``ESMINI_HOME``)."""

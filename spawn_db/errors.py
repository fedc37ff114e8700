"""The exceptions of ``spawn_db``: one root, :class:`SpawnDbError`, for everything it raises
but a params dict it cannot place (``errors.ParamsError``, shared with the reference scripts)."""

from __future__ import annotations

from scenweave.errors import InfrastructureError, ScenarioError, ScenWeaveError


class SpawnDbError(ScenWeaveError):
    """Root of every error raised by ``spawn_db``."""


class SpawnDatabaseError(SpawnDbError, InfrastructureError):
    """The spawn database file is missing or does not match its JSON Schema."""


class NoSpawnFits(SpawnDbError, ScenarioError):
    """No spawn point of the database satisfies the scenario's constraints."""

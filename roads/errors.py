"""The exceptions of ``roads``: one root, :class:`RoadError`, for everything it raises."""

from __future__ import annotations

from scenweave.errors import InputError, ScenarioError, ScenWeaveError


class RoadError(ScenWeaveError):
    """Root of every error raised by ``roads``."""


class OpenDriveError(RoadError, InputError):
    """The OpenDRIVE file is missing, malformed or uses a feature this reader does not support."""


class LaneEndsError(RoadError, ScenarioError):
    """A walk along a lane ran into the end of the drivable network."""


class UnknownMapError(RoadError, InputError, ValueError):
    """A map name that is not bundled, or a map file that does not exist."""


class RecordedRoadError(RoadError, InputError):
    """A recorded lane network that cannot be written as OpenDRIVE; the message names the
    file (where known) and the lanelet."""

"""Manoeuvre classes: one definition per class, asked by every stage.

See ``docs/adding-a-manoeuvre.md``. ``get("BRAKE")`` -> :class:`Maneuver`;
``codes("urban")``; ``maneuvers()``; a plugin adds classes (``plugins``, ``docs/plugins.md``).
This package imports nothing else of ScenWeave's.
"""

from scenweave.maneuvers.maneuver import (
    Domain,
    Maneuver,
    RecordFieldError,
    SameLane,
    no_lane_sides,
)
from scenweave.maneuvers.registry import (
    PLUGINS_ENV,
    UnknownManeuver,
    by_tag,
    codes,
    find,
    get,
    maneuvers,
    register,
    seeding_order,
    unregister,
)

__all__ = ["PLUGINS_ENV", "Domain", "Maneuver", "RecordFieldError", "SameLane",
           "UnknownManeuver", "by_tag", "codes", "find", "get", "maneuvers", "no_lane_sides",
           "register", "seeding_order", "unregister"]

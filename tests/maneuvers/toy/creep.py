"""A toy urban class, added from outside ScenWeave's code: U9_1, the ego creeps up to a red
light and stops at its line (an urban class's needs: a light over its movement, decided when a
spawn is matched, not when the spawn database was built). Its script reuses the stop-at-red
reference through the corpus's public ``generate``."""

from __future__ import annotations

from pathlib import Path

from scenweave.maneuvers import Maneuver

MANEUVERS = (
    Maneuver(code="U9_1", tag="creep_to_red", domain="urban", name="Ego creeps up to red",
             script=str(Path(__file__).with_name("gen_ur_creep_to_red.py")), light="red",
             stops_at_line=True, verb="creeps up to"),
)

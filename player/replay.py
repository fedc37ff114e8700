"""One replay: translate a delivered scenario for esmini, play it, return the ``Playback``."""

from __future__ import annotations

import tempfile
from pathlib import Path

from lxml import etree

from player.engine import play_file
from player.errors import PlayerUnavailable
from player.locate import find_esmini
from player.maps import esmini_map
from player.playback import Playback
from player.settings import ReplaySettings
from player.translate import TranslationError, translate

#: the playback's file in a scenario folder
REPLAY_NAME = "replay.json"


def replay_file(xosc_path: Path, map_path: Path,
                settings: ReplaySettings | None = None) -> Playback:
    """Play ``xosc_path`` (CARLA dialect) on ``map_path`` headless; what happened.

    A scenario esmini cannot load, aborts on, or plays past the wall-clock limit gives a
    playback with ``engine_error`` set. Raises only ``PlayerUnavailable`` (no esmini here).
    """
    import spawn_db

    settings = settings or ReplaySettings()
    find_esmini()  # raises PlayerUnavailable with what was tried
    xosc_text = Path(xosc_path).read_bytes()
    try:
        translated = translate(xosc_text, esmini_map(map_path),
                               spawn_db.traffic_lights_carla(map_path))
    except TranslationError as err:
        return Playback(engine_error=f"translation for esmini: {err}")
    until_s = scenario_duration_s(xosc_text, settings.default_duration_s)
    with tempfile.TemporaryDirectory(prefix="scenweave-replay-") as tmp:
        copy = Path(tmp) / "scenario.esmini.xosc"
        copy.write_bytes(translated.xml)
        playback = play_file(copy, until_s, settings.time_step_s, settings.wall_time_s)
    playback.lights = translated.light_actions
    return playback


def scenario_duration_s(xosc_text: bytes, default_s: float) -> float:
    """How long the scenario plays: the largest time of its Storyboard stop trigger."""
    try:
        root = etree.fromstring(xosc_text)
    except etree.XMLSyntaxError:
        return default_s
    times = [float(c.get("value")) for c in
             root.iterfind("Storyboard/StopTrigger//SimulationTimeCondition")
             if _is_number(c.get("value"))]
    return max(times) if times else default_s


def player_status() -> dict:
    """What ``scenweave doctor`` shows: the player found, its version, or why it is missing."""
    try:
        install = find_esmini()
    except PlayerUnavailable as err:
        return {"available": False, "problem": str(err)}
    return {"available": True, **install.to_dict()}


def _is_number(text: str | None) -> bool:
    try:
        float(text or "")
    except ValueError:
        return False
    return True

"""CARLA's dialect -> what esmini loads, in a temporary copy used only for the replay.

Three constructs of a ScenWeave scenario mean something in CARLA that esmini does not read:
- ``RoadNetwork/LogicFile filepath="Town04"`` names a CARLA town, not a file: the copy points
  at the map file (prepared, see ``player.maps``);
- ``TrafficSignalStateAction name="pos=x,y"`` (CARLA frame) names a light by where it stands:
  the copy names the map's nearest dynamic signal by its OpenDRIVE id;
- the ``state`` of that action is a colour (green, yellow, red) for CARLA; esmini wants one mode
  per lamp of the signal, top to bottom (type 1000001: red; yellow; green).
The delivered ``.xosc`` is never touched.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from scenweave.player.errors import PlayerError

#: CARLA light colour -> esmini lamp modes of a three-lamp light (red; yellow; green)
LAMP_MODES = {"green": "off;off;on", "yellow": "off;on;off", "red": "on;off;off",
              "off": "off;off;off"}
#: a ``pos=`` light is tied to a signal standing at most this far from the named point (m)
LIGHT_MATCH_M = 2.0


class TranslationError(PlayerError):
    """A scenario construct could not be translated for the player (names the construct)."""


@dataclass
class Translated:
    """The esmini copy of a scenario and what the translation decided."""

    xml: bytes
    #: action name -> the colour it sets (CARLA's state), for the light timeline
    light_actions: dict[str, str] = field(default_factory=dict)
    #: action name -> the OpenDRIVE signal id it drives
    light_signals: dict[str, str] = field(default_factory=dict)


def translate(xosc_text: bytes, map_file: Path,
              lights_carla: Mapping[str, tuple[float, float]]) -> Translated:
    """The esmini copy of ``xosc_text``, playing on ``map_file``.

    ``lights_carla`` maps each dynamic signal id of the map to its position in CARLA's frame
    (``roads.traffic_lights_carla``), what ``pos=x,y`` names are resolved against.
    """
    try:
        root = etree.fromstring(xosc_text)
    except etree.XMLSyntaxError as err:
        raise TranslationError(f"the scenario is not XML: {err}") from err
    set_map_file(root, map_file)
    translated = Translated(b"")
    for action in root.iter("TrafficSignalStateAction"):
        _translate_light(action, lights_carla, translated)
    translated.xml = etree.tostring(root, xml_declaration=True, encoding="utf-8")
    return translated


def set_map_file(scenario: etree._Element, map_file: Path) -> None:
    """Point the scenario's ``RoadNetwork/LogicFile`` at ``map_file``."""
    logic = scenario.find("RoadNetwork/LogicFile")
    if logic is None:
        raise TranslationError("the scenario has no RoadNetwork/LogicFile")
    logic.set("filepath", str(map_file))


def _translate_light(action: etree._Element, lights_carla: Mapping[str, tuple[float, float]],
                     translated: Translated) -> None:
    name, state = action.get("name") or "", (action.get("state") or "").lower()
    signal_id = _signal_id(name, lights_carla)
    if state not in LAMP_MODES:
        raise TranslationError(f"TrafficSignalStateAction state {state!r} is not one of "
                               f"{sorted(LAMP_MODES)}")
    action.set("name", signal_id)
    action.set("state", LAMP_MODES[state])
    owner = action.getparent()
    while owner is not None and owner.tag != "Action":
        owner = owner.getparent()
    owner_name = owner.get("name") if owner is not None else None
    key = name if owner_name is None else owner_name  # the schema requires Action's name
    translated.light_actions[key] = state
    translated.light_signals[key] = signal_id


def _signal_id(name: str, lights_carla: Mapping[str, tuple[float, float]]) -> str:
    if not name.startswith("pos="):
        if name in lights_carla:
            return name
        raise TranslationError(f"traffic light {name!r} is neither pos=x,y nor a signal id of "
                               "the map")
    try:
        x, y = (float(v) for v in name[4:].split(","))
    except ValueError as err:
        raise TranslationError(f"traffic light {name!r}: pos= needs two numbers") from err
    best = min(lights_carla.items(), key=lambda item: math.dist(item[1], (x, y)),
               default=None)
    if best is None or math.dist(best[1], (x, y)) > LIGHT_MATCH_M:
        raise TranslationError(f"no traffic light of the map stands within {LIGHT_MATCH_M} m of "
                               f"{name} (CARLA frame)")
    return best[0]

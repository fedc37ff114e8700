"""One replay: translate a delivered scenario for esmini, play it, return the ``Playback``."""

from __future__ import annotations

import time
from pathlib import Path

from lxml import etree

from scenweave.player import maps
from scenweave.player.engine import TIMEOUT_MESSAGE, play_xml, warm_up
from scenweave.player.errors import PlayerUnavailable
from scenweave.player.locate import find_esmini
from scenweave.player.playback import Playback
from scenweave.player.settings import ReplaySettings
from scenweave.player.translate import TranslationError, set_map_file, translate

#: the playback's file in a scenario folder
#: what the translation writes as the map file before the copy to play on is chosen
_MAP_PLACEHOLDER = Path("map.xodr")

_lights: dict[maps.MapIdentity, dict[str, tuple[float, float]]] = {}


def replay_file(xosc_path: Path, map_path: Path,
                settings: ReplaySettings | None = None) -> Playback:
    """Play ``xosc_path`` (CARLA dialect) on ``map_path`` headless; what happened.

    The scenario plays on a copy of the map cut to the roads it reaches (``player.maps``;
    ``settings.cut_map``); if an entity left them, or esmini failed on the cut copy, it is
    played again on the whole map, so the cut never changes the playback. A scenario esmini
    cannot load, aborts on, or plays past the wall-clock limit gives a playback with
    ``engine_error`` set. Raises only ``PlayerUnavailable`` (no esmini here).

    ``timings_s`` splits the wall time: ``translate`` (reading and translating the file),
    ``plan`` (choosing the roads), ``map`` (writing the map copy, once per process and road
    set), ``start`` (until the player process runs), ``load`` (esmini reading scenario and
    map), ``step``, ``collect`` (the playback back to the caller), ``total``; ``map_km`` and
    ``map_share`` say how much road was loaded, ``replays`` how often it played (2: again on
    the whole map, ``first_replay`` the first one's seconds).
    """
    started = time.perf_counter()
    settings = settings or ReplaySettings()
    find_esmini()  # raises PlayerUnavailable with what was tried
    warm_up()
    xosc_text = Path(xosc_path).read_bytes()
    try:
        translated = translate(xosc_text, _MAP_PLACEHOLDER, _lights_of(map_path))
        scenario = etree.fromstring(translated.xml)
    except TranslationError as err:
        return Playback(engine_error=f"translation for esmini: {err}")
    until_s = _duration(scenario, settings.default_duration_s)
    translated_at = time.perf_counter()
    cut = maps.MapCut(None, reason="ReplaySettings.cut_map is off")
    if settings.cut_map:
        try:
            cut = maps.plan_cut(scenario, map_path, until_s + settings.time_step_s,
                                translated.light_signals.values())
        except Exception as err:  # noqa: BLE001 - a fault of the cut must not cost the replay
            cut = maps.MapCut(None, reason=f"planning the cut failed: {err!r}")
    planned_at = time.perf_counter()
    playback, map_s = _play(scenario, map_path, cut, until_s, settings)
    replays = 1
    timed_out = (playback.engine_error or "").startswith(TIMEOUT_MESSAGE)
    if not cut.whole and not timed_out and (playback.engine_error
                                            or not cut.covers(playback.tracks)):
        cut = maps.MapCut(None, kept_m=cut.map_m, map_m=cut.map_m,
                          reason="the replay on the cut map left its roads or failed")
        first_s = playback.timings_s.get("total", 0.0)
        playback, more_map_s = _play(scenario, map_path, cut, until_s, settings)
        map_s += more_map_s
        replays = 2
        playback.timings_s["first_replay"] = first_s
    playback.lights = translated.light_actions
    carla_xy = _lights_of(map_path)
    playback.light_positions = {action: [carla_xy[signal][0], -carla_xy[signal][1]]
                                for action, signal in translated.light_signals.items()
                                if signal in carla_xy}
    playback.map = str(map_path)
    playback.timings_s.update({"translate": round(translated_at - started, 4),
                               "plan": round(planned_at - translated_at, 4),
                               "map": round(map_s, 4), "replays": replays,
                               "total": round(time.perf_counter() - started, 4)})
    if cut.map_m:
        playback.timings_s["map_km"] = round(cut.kept_m / 1000, 3)
        playback.timings_s["map_share"] = round(cut.kept_m / cut.map_m, 3)
    return playback


def esmini_input(xosc_path: Path, map_path: Path,
                 settings: ReplaySettings | None = None) -> tuple[bytes, float]:
    """What ``replay_file`` hands esmini first: the translated scenario pointing at the cut
    copy of the map (written), and the time it plays until; for timing esmini bare
    (``benchmarks/scale.py``). Raises ``TranslationError`` for a file it cannot translate."""
    settings = settings or ReplaySettings()
    translated = translate(Path(xosc_path).read_bytes(), _MAP_PLACEHOLDER, _lights_of(map_path))
    scenario = etree.fromstring(translated.xml)
    until_s = _duration(scenario, settings.default_duration_s)
    cut = maps.plan_cut(scenario, map_path, until_s + settings.time_step_s,
                        translated.light_signals.values()) if settings.cut_map else \
        maps.MapCut(None, reason="ReplaySettings.cut_map is off")
    set_map_file(scenario, maps.cut_map(map_path, cut.roads))
    return etree.tostring(scenario, xml_declaration=True, encoding="utf-8"), until_s


def _play(scenario: etree._Element, map_path: Path, cut: maps.MapCut, until_s: float,
          settings: ReplaySettings) -> tuple[Playback, float]:
    """Play ``scenario`` on the copy of the map ``cut`` names; the seconds spent writing it."""
    started = time.perf_counter()
    map_file = maps.cut_map(map_path, cut.roads)
    map_s = time.perf_counter() - started
    set_map_file(scenario, map_file)
    xml = etree.tostring(scenario, xml_declaration=True, encoding="utf-8")
    return play_xml(xml, until_s, settings.time_step_s, settings.wall_time_s), map_s


def _lights_of(map_path: Path) -> dict[str, tuple[float, float]]:
    """``roads.traffic_lights_carla`` of the map, once per process and file version."""
    key = maps.map_identity(map_path)
    if key not in _lights:
        from scenweave import roads

        _lights[key] = roads.traffic_lights_carla(map_path)
    return _lights[key]


def scenario_duration_s(xosc_text: bytes, default_s: float) -> float:
    """How long the scenario plays: the largest time of its Storyboard stop trigger."""
    try:
        root = etree.fromstring(xosc_text)
    except etree.XMLSyntaxError:
        return default_s
    return _duration(root, default_s)


def _duration(root: etree._Element, default_s: float) -> float:
    values = (c.get("value") for c in
              root.iterfind("Storyboard/StopTrigger//SimulationTimeCondition"))
    times = [float(v) for v in values if v is not None and _is_number(v)]
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

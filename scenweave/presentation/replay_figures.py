"""A picture of one replay: what esmini did with a scenario, against what the record says.

``draw_replay_figure(scenario_dir)`` reads the folder's ``replay.json`` (``player.Playback``),
``params.json``, ``status.json`` and ``scenario.xosc`` and writes ``replay.svg`` beside them:

- top left, each actor's speed over the replay (lines) with the record's values marked: the
  start speed at t = 0 (circle) and each scripted speed change's target where it should be
  reached (diamond, at start + duration), the bars the judge's tolerance; the manoeuvre window
  (``maneuver_start_s`` .. + ``duration_s``) shaded;
- bottom left, highway: every other vehicle's gap to the ego along its lane
  (``judge.replay.gap_along_lane``, measured at the marked times and every ``GAP_ANCHOR_S`` or
  coarser on long replays, and carried between those by the distances both drove) with the
  record's gaps marked (``*_distance_m`` at the manoeuvre start, FL also
  ``npc_distance_end_m`` at its end); urban: the distance the ego drove against the stop line,
  the traffic light's colour behind it and the lead's gap if there is one;
- right, a bird's-eye view in the OpenDRIVE frame: the lanes of the map near the paths (drawn
  from the ``roads`` network), each actor's path in its colour from its start (dot) to its
  end (square), collisions as a red X with their time, the turn's exit and the stop line of the
  record where the class has them.

The title says whether the replay passed; a failed one lists its ``REPLAY_*`` findings (from
``status.json``) under the plots. A folder without ``replay.json`` gets no figure; a playback
esmini could not play gets a figure saying why. Every figure has the same size
(``FIGURE_PX``), so a page of them lines up.

This module only computes what is drawn, in figure coordinates (pixels, y down), with the
chart primitives of ``scenweave.charts`` (scales, ticks at nice numbers, lines as SVG path
data, marks, legends). ``templates/replay_figure.svg`` (which extends ``chart.svg``) draws it
(Jinja2, every value escaped: a record's text is shown, never run).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import textwrap
from collections.abc import Callable, Mapping, Sequence
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from scenweave.charts import (
    CAPTION_PX,
    DASH_DOT,
    DASHED,
    DOTTED,
    LABEL_PX,
    TITLE_PX,
    Chart,
    Entry,
    Panel,
    Plot,
    Scale,
    Stroke,
    Text,
    path_data,
    render_svg,
)
from scenweave.files.atomic import write_text_atomic
from scenweave.judge.replay import GAP_TOL_M, SPEED_TOL_MS, gap_along_lane
from scenweave.player import REPLAY_NAME, Playback
from scenweave.run_folder import RECORDED_NAME
from scenweave.scenario_lib.vehicles import reference_gap_m
from scenweave.schemas.params import number as number_of

FIGURE_NAME = "replay.svg"
TEMPLATE = "replay_figure.svg"
#: the figure's size in pixels, the same for every replay
FIGURE_PX = (900, 504)
#: the namespace of the ``<metadata>`` element naming what the figure shows (``figure_source``)
SOURCE_NS = "urn:scenweave:replay-figure"
_SOURCE_PATTERN = re.compile(r"<sw:source[^>]*>([0-9a-f]{64})</sw:source>")
#: the gap is measured along the lanes this often (s; each measurement ~1 ms), coarser when
#: a long replay with several vehicles would need more than MAX_GAP_ANCHORS of them, and at
#: the record's marked times; between two measurements it follows the distances driven
GAP_ANCHOR_S = 2.0
MAX_GAP_ANCHORS = 16
#: metres of map shown around the paths
MAP_MARGIN_M = 20.0
#: at most this many findings are listed under the plots
MAX_CAPTION_LINES = 4
EGO = "hero"
EGO_COLOUR = "#1f4e9c"
OTHER_COLOURS = ("#e07b00", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")
LIGHT_COLOURS = {"green": "#2ca02c", "yellow": "#f2c200", "red": "#d62728"}
FAIL_COLOUR = "#cf222e"
PASS_COLOUR = "#1a7f37"
#: the panels' frames (x, y, width, height) in pixels
SPEED_FRAME = (58.0, 46.0, 422.0, 176.0)
LOWER_FRAME = (58.0, 234.0, 422.0, 166.0)
MAP_FRAME = (552.0, 46.0, 336.0, 354.0)
CAPTION_TOP = 446.0
#: the map's lanes keep one point per this many pixels: they bend gently at its scale (a
#: chord of 6 px misses a 20 px radius by 0.2 px)
LANE_THIN_PX = 6.0


def draw_replay_figure(scenario_dir: Path, map_path: Path | str | None = None,
                       status: dict | None = None) -> Path | None:
    """Write ``replay.svg`` into ``scenario_dir`` and return its path; None without a replay.

    ``map_path`` is the OpenDRIVE map the scenario was played on (default: the one its params
    or its ``LogicFile`` name, else Town04); ``status`` the scenario's outcome when its
    ``status.json`` is not written yet (a figure drawn in the worker, before the commit). Never
    raises for a problem of the files read: an unreadable ``replay.json`` or a playback with an
    engine error gets a figure that says so. The SVG names what it shows (``figure_source``,
    in its ``<metadata>``), so a reader can tell a stale figure without trusting file times.
    """
    folder = Path(scenario_dir)
    replay_path = folder / REPLAY_NAME
    if not replay_path.is_file():
        return None
    facts = _Facts.read(folder)
    if status is not None:
        facts.status = status
    played, playback = _read_playback(replay_path)
    if isinstance(playback, Exception):
        figure = _message_figure(facts, "replay.json could not be read",
                                 f"{type(playback).__name__}: {playback}")
    elif playback.engine_error or not playback.times:
        figure = _message_figure(facts, "esmini could not play the scenario",
                                 playback.engine_error or "esmini recorded no step",
                                 playback.log[-6:])
    else:
        try:
            figure = _replay_figure(playback, facts, map_path or facts.map_path)
        except (KeyError, IndexError, ValueError, TypeError) as err:  # a malformed playback
            figure = _message_figure(facts, "the replay could not be drawn",
                                     f"{type(err).__name__}: {err}")
    out = folder / FIGURE_NAME
    write_text_atomic(out, render_svg(figure, TEMPLATE,
                                      source=_source_of(played, facts.status),
                                      source_ns=SOURCE_NS))
    return out


def is_reported(outcome: dict, index: int) -> bool:
    """Whether a scenario's figure is one a run's report will show, so the worker that made
    the scenario draws it (in parallel) instead of the report at the end: every failed replay,
    and the first scenario of each class (``index`` 0), the one shown when it passes."""
    replay = outcome.get("replay")
    return isinstance(replay, dict) and bool(replay) and (not replay.get("passed") or index == 0)


def figure_source(folder: Path, status: dict) -> str:
    """What a figure of ``folder`` shows, as a digest: the playback and the verdict on it."""
    return _source_of(_played(folder), status)


def is_current(folder: Path, status: dict) -> bool:
    """True when the folder's ``replay.svg`` was drawn from its present replay and verdict."""
    try:
        with open(folder / FIGURE_NAME, encoding="utf-8", errors="replace") as handle:
            head = handle.read(4096)
    except OSError:
        return False
    drawn = _SOURCE_PATTERN.search(head)
    return drawn is not None and drawn.group(1) == figure_source(folder, status)


def _played(folder: Path) -> Any:
    """``replay.json`` as read (None when it cannot be)."""
    try:
        return json.loads((folder / REPLAY_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _read_playback(path: Path) -> tuple[Any, Playback | Exception]:
    """``replay.json`` as read (None when it cannot be) and its playback, or why there is
    none; read once for the figure and for what it shows."""
    played = None
    try:
        played = json.loads(path.read_text(encoding="utf-8"))
        return played, Playback.from_dict(played)
    except (OSError, ValueError, TypeError, KeyError, AttributeError) as err:
        return played, err


def _source_of(played: Any, status: dict) -> str:
    raw = status.get("replay")
    replay: dict[str, Any] = raw if isinstance(raw, dict) else {}
    verdict = {"passed": replay.get("passed"), "codes": replay.get("codes"),
               "errors": (status.get("validation") or {}).get("errors")}
    if isinstance(played, dict):  # how long the replay took is no part of what it shows
        played = {k: v for k, v in played.items() if k != "timings_s"}
    shown = json.dumps([played, verdict], sort_keys=True, default=str).encode()
    return hashlib.sha256(shown).hexdigest()


# --- what the folder says --------------------------------------------------------------------

class _Facts:
    """The record's values (params), the replay's verdict (status) and the scenario's
    storyboard (for the scripted speed changes), each possibly missing."""

    def __init__(self, folder: Path, params: Mapping[str, Any], status: dict, doc: Any):
        self.folder, self.params, self.status, self.doc = folder, params, status, doc

    @classmethod
    def read(cls, folder: Path) -> _Facts:
        return cls(folder, _read_json(folder / "params.json"), _read_json(folder / "status.json"),
                   _scenario_doc(folder / "scenario.xosc"))

    @property
    def scenario_id(self) -> str:
        return str(self.params.get("scenario_id") or self.status.get("scenario_id")
                   or self.folder.name)

    @property
    def maneuver_class(self) -> str:
        return str(self.params.get("maneuver_class") or self.status.get("maneuver_class") or "?")

    @property
    def replay(self) -> dict | None:
        replay = self.status.get("replay")
        return replay if isinstance(replay, dict) else None

    def findings(self) -> list[str]:
        """The replay's findings as ``CODE message`` lines (status.json's validation errors),
        or only the codes when the messages were not kept."""
        validation = self.status.get("validation") or {}
        lines = [f"{e.get('code')} {e.get('message', '')}".strip()
                 for e in validation.get("errors") or []
                 if isinstance(e, dict) and str(e.get("code", "")).startswith("REPLAY")]
        if not lines and self.replay:
            lines = [str(c) for c in self.replay.get("codes") or []]
        return lines

    def verdict(self) -> tuple[str, str]:
        """The title's verdict and its colour."""
        replay = self.replay
        if replay is None:
            return "replay not judged", "black"
        if replay.get("passed"):
            return "replay passed", PASS_COLOUR
        codes = replay.get("codes") or []
        return "replay FAILED" + (f": {', '.join(codes)}" if codes else ""), FAIL_COLOUR

    @cached_property
    def recorded(self) -> dict:
        """What a mined record recorded (``recorded.json``, else params ``recorded_series``;
        empty for other records)."""
        return _read_json(self.folder / RECORDED_NAME) or self.params.get("recorded_series") or {}

    def recorded_curve(self, key: str) -> tuple[np.ndarray, np.ndarray] | None:
        """(scenario time, values) of a recorded series: the record's event starts when the
        scenario's manoeuvre does."""
        recorded = self.recorded
        values = recorded.get(key)
        if not values or "t" not in recorded:
            return None
        shift = self.number("maneuver_start_s") or 0.0
        times = np.asarray(recorded["t"], dtype=float) + shift
        return times, np.asarray([math.nan if v is None else v for v in values], dtype=float)

    @property
    def map_path(self) -> Path | None:
        """The map the scenario was made for (params ``map``, else its LogicFile)."""
        from scenweave import roads

        try:
            return roads.resolve_map(self.params.get("map") or (
                self.doc.logic_file if self.doc is not None else None)).path
        except roads.UnknownMapError:
            return None

    def number(self, key: str) -> float | None:
        return number_of(self.params, key)


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _scenario_doc(path: Path) -> Any:
    from lxml import etree

    from scenweave.judge.scenario_doc import ScenarioDoc

    try:
        return ScenarioDoc(etree.parse(str(path)))
    except (OSError, etree.XMLSyntaxError):
        return None


# --- the figure ------------------------------------------------------------------------------

def _title(facts: _Facts) -> Text:
    verdict, colour = facts.verdict()
    return Text(9, 19, f"{facts.scenario_id} · {facts.maneuver_class} · {verdict}", TITLE_PX,
                colour, cls="title")


def _message_figure(facts: _Facts, headline: str, detail: str,
                    log: list[str] | None = None) -> Chart:
    lines = [headline, "", *textwrap.wrap(detail, 110)[:8]]
    if log:
        lines += ["", "esmini's last log lines:", *(textwrap.shorten(line, 120) for line in log)]
    colour = FAIL_COLOUR if facts.replay else "black"
    title = _title(facts)
    return Chart(title.text, *FIGURE_PX, texts=[title, *(Text(36, 64 + 15 * i, line, 11.25,
                                                               colour, mono=True, cls="message")
                                                          for i, line in enumerate(lines)
                                                          if line)])


def _replay_figure(playback: Playback, facts: _Facts, map_path: Any) -> Chart:
    colours = _colours(playback)
    times = (0.0, max(playback.duration_s, 0.1))
    speed = Plot("speed", SPEED_FRAME)
    _speed_panel(speed, playback, facts, colours)
    lower = Plot("lower", LOWER_FRAME)
    if facts.params.get("domain") == "urban":
        _urban_panel(lower, playback, facts, colours, map_path)
        lower_label = "metres"
    else:
        _gap_panel(lower, playback, facts, colours, map_path)
        lower_label = "gap to ego along lane (m)"
    for plot in (speed, lower):
        for time_s in _first_collisions(playback):
            plot.vline(time_s, FAIL_COLOUR, 1.25, DOTTED)
    title = _title(facts)
    return Chart(title.text, *FIGURE_PX, panels=[
        speed.finish(speed.auto_scales(times), x_labels=False, y_label="speed (m/s)"),
        lower.finish(lower.auto_scales(times), x_label="time (s)", y_label=lower_label),
        _map_panel(playback, facts, colours, map_path),
    ], texts=[title, *_caption(facts, playback.series_errors)])


def _colours(playback: Playback) -> dict[str, str]:
    others = [e for e in playback.entities if e != EGO]
    colours = {name: OTHER_COLOURS[i % len(OTHER_COLOURS)] for i, name in enumerate(others)}
    colours[EGO] = EGO_COLOUR
    return colours


def _caption(facts: _Facts, series_errors: dict | None = None) -> list[Text]:
    findings = facts.findings()
    if not findings:
        lines = (["replay as recorded: no REPLAY_* finding"] if facts.replay and
                 facts.replay.get("passed") else [])
    else:
        lines = [textwrap.shorten(line, 150, placeholder=" …") for line in
                 findings[:MAX_CAPTION_LINES]]
        if len(findings) > MAX_CAPTION_LINES:
            lines[-1] = f"… and {len(findings) - MAX_CAPTION_LINES + 1} more findings " \
                        "(status.json)"
    if series_errors:  # the whole record, sample by sample (judge.replay)
        lines.append("against the recorded series: " + "; ".join(
            f"{name} max {e['max']:.2f} / RMS {e['rms']:.2f}" for name, e in series_errors.items()))
    colour = FAIL_COLOUR if findings else PASS_COLOUR
    return [Text(9, CAPTION_TOP + 12 * i, line, CAPTION_PX, colour, cls="caption")
            for i, line in enumerate(lines)]


def _first_collisions(playback: Playback) -> list[float]:
    """The time each colliding pair first touches."""
    first: dict[tuple[str, str], float] = {}
    for time_s, a, b in playback.collisions:
        first.setdefault((a, b), float(time_s))
    return sorted(set(first.values()))


# --- speed -----------------------------------------------------------------------------------

def _speed_panel(plot: Plot, playback: Playback, facts: _Facts, colours: dict[str, str]) -> None:
    from scenweave.judge.fidelity import placed_actors

    start, duration = facts.number("maneuver_start_s"), facts.number("duration_s")
    if start is not None and duration is not None:
        plot.span(start, start + duration, "#888888", 0.13)
        plot.legend.append(Entry("manoeuvre (record)", "#888888", patch=True))
    for name in playback.entities:
        plot.line(playback.times, playback.tracks[name]["speed"], colours[name], 1.6)
        plot.legend.append(Entry(name, colours[name]))
    plot.legend += _recorded_lines(plot, facts, colours, "speed_ms", lambda v: v)
    for name, prefix in placed_actors(facts.params):
        value = facts.number(f"{prefix}_speed_ms")
        if value is not None and name in colours:
            plot.mark(0.0, value, "circle", colours[name], 6.25, fill="white",
                      tolerance=SPEED_TOL_MS, clip=False)
    for name, target, at_s in _speed_targets(facts):
        if name in colours:
            plot.mark(at_s, target, "diamond", colours[name], 6.25, fill="white",
                      tolerance=SPEED_TOL_MS)
    plot.legend += [Entry("record: start speed", mark="circle"),
                    Entry("record: target speed", mark="diamond")]
    plot.legend_columns = 2


def _speed_targets(facts: _Facts) -> list[tuple[str, float, float]]:
    """(entity, target speed, when it should be reached) of every scripted speed change."""
    from scenweave.judge.fidelity import SpeedChange, expected_speed_changes, speed_targets

    changes: list[SpeedChange] = []
    if facts.doc is not None:
        try:
            changes = expected_speed_changes(facts.doc, facts.params)
        except (KeyError, TypeError, ValueError, AttributeError):
            changes = []
    elif facts.number("ego_end_speed_ms") is not None:
        changes = [("hero_speed_change", facts.number("ego_end_speed_ms"),
                    facts.number("duration_s"), facts.number("maneuver_start_s"))]
    return speed_targets(changes)


def _recorded_lines(plot: Plot, facts: _Facts, colours: dict[str, str], what: str,
                    convert: Callable[[np.ndarray], Any]) -> list[Entry]:
    """The mined record's own series, dashed, beside the replay's curves (``what``: speed_ms
    or gap_m; ``convert`` turns recorded values into the panel's)."""
    drawn = []
    for role, entity in (("ego", EGO), ("npc", "npc")):
        curve = facts.recorded_curve(f"{role}_{what}")
        if curve is not None and entity in colours:
            plot.line(curve[0], convert(curve[1]), colours[entity], 1.4, DASHED)
            drawn.append(entity)
    return [Entry("recorded (mined data)", dash=DASHED)] if drawn else []


# --- gap (highway) ---------------------------------------------------------------------------

def _anchor_times(playback: Playback, series: int, marked: list[float]) -> list[float]:
    """When the gap is measured: every GAP_ANCHOR_S (coarser when ``series`` curves would need
    more than MAX_GAP_ANCHORS measurements), the end, and the marked times themselves so the
    record's values meet a measured point."""
    span = playback.duration_s
    step = max(GAP_ANCHOR_S, span * max(1, series) / MAX_GAP_ANCHORS)
    times = np.arange(0.0, span + 1e-9, step).tolist()
    if times[-1] < span - 1e-6:
        times.append(span)
    return sorted(set(times) | {t for t in marked if 0.0 <= t <= span})


def _lane_change_times(playback: Playback, entity: str) -> list[float]:
    """The samples either side of each lane change of ``entity`` or the ego: the gap, measured
    on another lane from there on, may jump."""
    from scenweave.judge.replay import lane_changes

    times = playback.times
    found = []
    for name in {EGO, entity}:
        for time_s, _ in lane_changes(playback, name):
            i = playback.index_at(time_s)
            found += [times[max(i - 1, 0)], times[i]]
    return found


def _gaps(playback: Playback, entity: str, times: Sequence[float], map_path: Any) -> np.ndarray:
    gaps = []
    for time_s in times:
        try:
            gap = gap_along_lane(playback, entity, time_s, map_path)
        except Exception:  # noqa: BLE001 - a picture shows what it can measure
            gap = None
        gaps.append(math.nan if gap is None else gap)
    return np.asarray(gaps, dtype=float)


def _gap_curve(playback: Playback, entity: str, anchors: list[float],
               map_path: Any) -> tuple[np.ndarray, np.ndarray]:
    """(times, gaps) of ``entity``: measured along the lanes at the ``anchors``, and between
    two measurements the difference of the distances the two drove, shifted linearly to meet
    both (the gap changes by what one drove more than the other; the shift takes up what
    lane changes and curves add). Missing where either measurement is."""
    measured = _gaps(playback, entity, anchors, map_path)
    played = np.asarray(playback.times, dtype=float)
    times = np.union1d(played, anchors)
    drift = np.interp(times, played, _driven(playback, entity) - _driven(playback, EGO))
    at = np.asarray(anchors, dtype=float)
    offsets = measured - np.interp(at, times, drift)
    if len(at) == 1:
        return times, drift + offsets[0]
    piece = np.clip(np.searchsorted(at, times, side="right") - 1, 0, len(at) - 2)
    share = np.clip((times - at[piece]) / (at[piece + 1] - at[piece]), 0.0, 1.0)
    return times, drift + offsets[piece] * (1 - share) + offsets[piece + 1] * share


def _recorded_gaps(facts: _Facts) -> list[tuple[str, float, float]]:
    """(entity, gap, time) of every gap the record has, as the judge compares them."""
    from scenweave.judge.fidelity import class_of, placed_actors

    start = facts.number("maneuver_start_s")
    if start is None:
        return []
    found = [(name, facts.number(f"{prefix}_distance_m"), start)
             for name, prefix in placed_actors(facts.params) if name != EGO]
    if class_of(facts.params).gap_at_end:
        found.append(("npc", facts.number("npc_distance_end_m"),
                      start + (facts.number("duration_s") or 0.0)))
    return [(name, gap, at_s) for name, gap, at_s in found if gap is not None]


def _gap_panel(plot: Plot, playback: Playback, facts: _Facts, colours: dict[str, str],
               map_path: Any) -> None:
    others = [e for e in playback.entities if e != EGO]
    if not others:
        plot.note("no other vehicle: no gap to show")
        return
    recorded = _recorded_gaps(facts)
    anchors = _anchor_times(playback, len(others), [t for _, _, t in recorded])
    kind = facts.params.get("npc_vehicle_type")
    mined = _recorded_lines(plot, facts, colours, "gap_m",
                            np.vectorize(lambda g: reference_gap_m(g, kind), otypes=[float]))
    for name in others:
        at = sorted(set(anchors) | set(_lane_change_times(playback, name)))
        plot.line(*_gap_curve(playback, name, at, map_path), colours[name], 1.6)
        plot.legend.append(Entry(name, colours[name]))
    for name, gap, at_s in recorded:
        if name in colours:
            plot.mark(at_s, gap, "diamond", colours[name], 6.25, fill="white",
                      tolerance=GAP_TOL_M)
    plot.hline(0.0, "black", 0.75)
    plot.legend += [Entry("record: gap", mark="diamond"), *mined]


# --- distance vs stop line (urban) -----------------------------------------------------------

def _driven(playback: Playback, entity: str) -> np.ndarray:
    """Metres driven from t = 0 at every sample (the trapezoid ``judge.replay.travelled``
    sums, kept for every step)."""
    speeds, times = np.asarray(playback.tracks[entity]["speed"]), np.asarray(playback.times)
    steps = (speeds[1:] + speeds[:-1]) / 2 * np.diff(times)
    return np.concatenate([[0.0], np.cumsum(steps)])


def _light_spans(playback: Playback) -> list[tuple[float, float, str]]:
    """(from, to, colour) of the scenario's light over the replay (as ``light_state``)."""
    started = playback.fired("action")
    changes = sorted((t, playback.lights[name]) for name, t in started.items()
                     if name in playback.lights)
    spans = []
    for i, (time_s, colour) in enumerate(changes):
        until = changes[i + 1][0] if i + 1 < len(changes) else playback.duration_s
        spans.append((time_s, until, colour))
    return spans


def _lead_line(plot: Plot, playback: Playback, facts: _Facts, colour: str,
               map_path: Any) -> None:
    """Where the lead is, counted from the ego's start like the ego's distance: its replayed
    gap at t = 0 plus what it drove (one lane measurement, not one per sample: in town the
    lanes branch and a gap that cannot be followed costs a long search)."""
    gap = float(_gaps(playback, "lead", [0.0], map_path)[0])
    if math.isfinite(gap):
        plot.line(playback.times, gap + _driven(playback, "lead"), colour, 1.5, DASH_DOT)
        plot.legend.append(Entry("lead: gap at start + distance driven", colour, DASH_DOT))
    recorded = facts.number("lead_distance_m")
    if recorded is not None:
        plot.mark(0.0, recorded, "diamond", colour, 6.25, fill="white", tolerance=GAP_TOL_M,
                  clip=False)
        plot.legend.append(Entry("record: lead gap", colour, mark="diamond"))


def _urban_panel(plot: Plot, playback: Playback, facts: _Facts, colours: dict[str, str],
                 map_path: Any) -> None:
    for begin, end, colour in _light_spans(playback):
        plot.span(begin, end, LIGHT_COLOURS.get(colour, "#cccccc"), 0.15)
    plot.line(playback.times, _driven(playback, EGO), colours[EGO], 1.6)
    plot.legend.append(Entry("ego: distance driven", colours[EGO]))
    stop_line = facts.number("spawn_stop_line_distance_m")
    if stop_line is not None:
        plot.hline(stop_line, "black", 1.1, DASHED)
        plot.legend.append(Entry(f"stop line (record, {stop_line:.1f} m)", dash=DASHED))
    if "lead" in playback.tracks:
        _lead_line(plot, playback, facts, colours["lead"], map_path)


# --- bird's-eye view -------------------------------------------------------------------------

def _map_panel(playback: Playback, facts: _Facts, colours: dict[str, str],
               map_path: Any) -> Panel:
    plot = Plot("map", MAP_FRAME)
    points = np.array([(x, y) for name in playback.entities
                       for x, y in zip(playback.tracks[name]["x"], playback.tracks[name]["y"],
                                       strict=False)
                       if math.isfinite(x) and math.isfinite(y)])
    exit_x, exit_y = facts.number("turn_exit_x"), facts.number("turn_exit_y")
    turn_exit = (exit_x, exit_y) if exit_x is not None and exit_y is not None else None
    extra = [turn_exit] if turn_exit is not None else []
    if not len(points):
        x, y, width, height = MAP_FRAME
        return Panel("map", MAP_FRAME, texts=[Text(x + width / 2, y + height / 2,
                                                   "no position recorded", LABEL_PX,
                                                   anchor="middle")])
    every = np.vstack([points, np.array(extra, dtype=float).reshape(-1, 2)])
    scales = _equal_scales(every.min(axis=0) - MAP_MARGIN_M, every.max(axis=0) + MAP_MARGIN_M)
    for name in playback.entities:  # the ego last, on top and thinner: a follower's path
        track = playback.tracks[name]  # often lies on the ego's
        ego = name == EGO
        plot.line(track["x"], track["y"], colours[name], 1.75 if ego else 3.5,
                  opacity=1.0 if ego else 0.75, group=("actor", name))
    for name in playback.entities:
        track = playback.tracks[name]
        plot.mark(track["x"][0], track["y"][0], "circle", colours[name], 6.25, edge="black",
                  edge_width=0.6)
        plot.mark(track["x"][-1], track["y"][-1], "square", colours[name], 5.0, fill="white")
    if turn_exit is not None:
        plot.mark(*turn_exit, "star", "black", 12.5)
        plot.legend.append(Entry("record: turn exit", mark="star"))
    _mark_stop_line(plot, playback, facts)
    x_carla, y_carla = facts.number("tfl_x_carla"), facts.number("tfl_y_carla")
    if x_carla is not None and y_carla is not None:  # CARLA's y points the other way
        plot.mark(x_carla, -y_carla, "square", "#ff9900", 7.5, edge="black", edge_width=0.6)
        plot.legend.append(Entry("traffic light", "#ff9900", mark="square"))
    _mark_collisions(plot, playback)
    panel = plot.finish(scales, x_label="x (m, OpenDRIVE)", y_label="y (m)",
                        title="paths: start ● end ■, collision ✕", grid="")
    panel.clipped[:0] = _lanes(map_path, scales)
    panel.groups.sort(key=lambda group: group.name == EGO)
    return panel


def _equal_scales(low: np.ndarray, high: np.ndarray) -> tuple[Scale, Scale]:
    """Scales around ``low``..``high`` with one metre as long across as up, filling the frame."""
    x, y, width, height = MAP_FRAME
    centre, span = (low + high) / 2, high - low
    metres = max(span[0] / width, span[1] / height)  # per pixel
    half_x, half_y = metres * width / 2, metres * height / 2
    return (Scale(float(centre[0] - half_x), float(centre[0] + half_x), x, x + width),
            Scale(float(centre[1] - half_y), float(centre[1] + half_y), y + height, y))


def _mark_collisions(plot: Plot, playback: Playback) -> None:
    seen: set[tuple[str, str]] = set()
    for time_s, a, b in playback.collisions:
        if (a, b) in seen or a not in playback.tracks or b not in playback.tracks:
            continue
        seen.add((a, b))
        x = (playback.value(a, "x", time_s) + playback.value(b, "x", time_s)) / 2
        y = (playback.value(a, "y", time_s) + playback.value(b, "y", time_s)) / 2
        plot.mark(x, y, "x", FAIL_COLOUR, 14.0, edge="white", edge_width=1.0, cls="collision")
        plot.label(x, y, f"{a}–{b} {float(time_s):.2f} s", FAIL_COLOUR, cls="collision-time")


def _mark_stop_line(plot: Plot, playback: Playback, facts: _Facts) -> None:
    """The record's stop line across the ego's path, where the ego has driven its distance."""
    stop_line = facts.number("spawn_stop_line_distance_m")
    if stop_line is None or EGO not in playback.tracks:
        return
    driven = _driven(playback, EGO)
    reached = np.nonzero(driven >= stop_line)[0]
    track = playback.tracks[EGO]
    if len(reached):
        i = int(reached[0])
        x, y, h = track["x"][i], track["y"][i], track["h"][i]
    else:  # not reached: the line lies ahead of where the ego stopped, along its heading
        ahead = stop_line - float(driven[-1])
        h = track["h"][-1]
        x, y = track["x"][-1] + ahead * math.cos(h), track["y"][-1] + ahead * math.sin(h)
    half = 2.5
    plot.line([x - half * math.sin(h), x + half * math.sin(h)],
              [y + half * math.cos(h), y - half * math.cos(h)], "black", 2.75)
    plot.legend.append(Entry("record: stop line"))


def _lanes(map_path: Any, scales: tuple[Scale, Scale]) -> list[Stroke]:
    """Every drivable lane's borders that come into the view, one path per kind (on a road,
    in a junction)."""
    sx, sy = scales
    try:
        lanes = _lane_borders(_network(map_path))
    except Exception:  # noqa: BLE001 - without the map the paths are still worth a look
        return []
    x0, x1, y0, y1 = sx.low, sx.high, sy.low, sy.high
    drawn = []
    for in_junction, colour, width in ((False, "#9a9a9a", 0.75), (True, "#cfcfcf", 0.6)):
        chosen = [line for bounds, junction, line in lanes if junction == in_junction
                  and bounds[0] <= x1 and bounds[1] >= x0 and bounds[2] <= y1 and bounds[3] >= y0]
        if chosen:
            gap = np.full((1, 2), np.nan)  # between two lines
            every = np.vstack([part for line in chosen for part in (line, gap)])
            drawn.append(Stroke(path_data(*_cropped(sx(every[:, 0]), sy(every[:, 1]), sx, sy),
                                           LANE_THIN_PX),
                                colour, width, cls="lanes"))
    return drawn


def _cropped(xs: np.ndarray, ys: np.ndarray, sx: Scale,
             sy: Scale) -> tuple[np.ndarray, np.ndarray]:
    """The points (pixels) in the view, and the first one out where a line leaves it: the
    others are missing (NaN)."""
    low_x, high_x = sorted((sx.start, sx.end))
    low_y, high_y = sorted((sy.start, sy.end))
    inside = (xs >= low_x) & (xs <= high_x) & (ys >= low_y) & (ys <= high_y)
    keep = inside.copy()
    keep[1:] |= inside[:-1]
    keep[:-1] |= inside[1:]
    return np.where(keep, xs, np.nan), np.where(keep, ys, np.nan)


def _network(map_path: Any) -> Any:
    from scenweave import roads

    return roads.road_network(map_path)


@lru_cache(maxsize=4)
def _lane_borders(network: Any) -> list[tuple[tuple[float, float, float, float], bool,
                                              np.ndarray]]:
    """(x0, x1, y0, y1), in a junction, (n, 2) points of each border of every drivable lane,
    sampled every ~2 m along the road (as spawn_db's map picture does). Once per map."""
    from scenweave.roads.lanes import lane_border_offsets, section_samples

    found = []
    for key in network.drivable_lanes():
        road = network.road(key.road_id)
        section = road.sections[key.section]
        s = section_samples(section)
        inner, outer = lane_border_offsets(road, section, key.lane_id, s)
        pose = road.plan_view.pose(s)
        for t in (inner[0], outer[0]):
            line = np.column_stack([pose.x - t * np.sin(pose.hdg), pose.y + t * np.cos(pose.hdg)])
            bounds = (float(line[:, 0].min()), float(line[:, 0].max()),
                      float(line[:, 1].min()), float(line[:, 1].max()))
            found.append((bounds, bool(road.in_junction), line))
    return found

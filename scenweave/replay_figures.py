"""A picture of one replay: what esmini did with a scenario, against what the record says.

``draw_replay_figure(scenario_dir)`` reads the folder's ``replay.json`` (``player.Playback``),
``params.json``, ``status.json`` and ``scenario.xosc`` and writes ``replay.png`` beside them:

- top left, each actor's speed over the replay (lines) with the record's values marked: the
  start speed at t = 0 (circle) and each scripted speed change's target where it should be
  reached (diamond, at start + duration), the bars the judge's tolerance; the manoeuvre window
  (``maneuver_start_s`` .. + ``duration_s``) shaded;
- bottom left, highway: every other vehicle's gap to the ego along its lane
  (``judge.replay.gap_along_lane``, sampled every ``GAP_STEP_S`` or coarser on long replays)
  with the record's gaps marked (``*_distance_m`` at the manoeuvre start, FL also
  ``npc_distance_end_m`` at its end); urban: the distance the ego drove against the stop line,
  the traffic light's colour behind it and the lead's gap if there is one;
- right, a bird's-eye view in the OpenDRIVE frame: the lanes of the map near the paths (drawn
  from ``spawn_db``'s road network), each actor's path in its colour from its start (dot) to its
  end (square), collisions as a red X with their time, the turn's exit and the stop line of the
  record where the class has them.

The title says whether the replay passed; a failed one lists its ``REPLAY_*`` findings (from
``status.json``) under the plots. A folder without ``replay.json`` gets no figure; a playback
esmini could not play gets a figure saying why. Every figure has the same size
(``FIGURE_PX``), so a page of them lines up.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import struct
import textwrap
import zlib
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from scenweave.corpus.corpus_utils import reference_gap_m
from scenweave.files.atomic import write_bytes_atomic
from scenweave.judge.replay import GAP_TOL_M, SPEED_TOL_MS, gap_along_lane
from scenweave.player import REPLAY_NAME, Playback
from scenweave.run_folder import RECORDED_NAME
from scenweave.schemas.params import number as number_of

FIGURE_NAME = "replay.png"
#: the PNG text chunk naming what the figure shows (``figure_source``)
SOURCE_KEY = "scenweave-source"
#: figure size (inches) and resolution: FIGURE_PX pixels, the same for every replay
FIGURE_IN = (10.0, 5.6)
DPI = 90
FIGURE_PX = (round(FIGURE_IN[0] * DPI), round(FIGURE_IN[1] * DPI))
PNG_COLOURS = 64
#: the gap is sampled this often (s); a long replay with several vehicles is sampled coarser
#: so that at most MAX_GAP_SAMPLES measurements are made (each follows the lanes, ~1 ms)
GAP_STEP_S = 0.25
MAX_GAP_SAMPLES = 160
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


def draw_replay_figure(scenario_dir: Path, map_path: Path | str | None = None,
                       status: dict | None = None) -> Path | None:
    """Write ``replay.png`` into ``scenario_dir`` and return its path; None without a replay.

    ``map_path`` is the OpenDRIVE map the scenario was played on (default: the one its params
    or its ``LogicFile`` name, else Town04); ``status`` the scenario's outcome when its
    ``status.json`` is not written yet (a figure drawn in the worker, before the commit). Never
    raises for a problem of the files read: an unreadable ``replay.json`` or a playback with an
    engine error gets a figure that says so. The PNG names what it shows (``figure_source``),
    so a reader can tell a stale figure without trusting file times.
    """
    folder = Path(scenario_dir)
    replay_path = folder / REPLAY_NAME
    if not replay_path.is_file():
        return None
    facts = _Facts.read(folder)
    if status is not None:
        facts.status = status
    try:
        playback = Playback.read(replay_path)
    except (OSError, ValueError, TypeError, KeyError, AttributeError) as err:
        png = _message_figure(facts, "replay.json could not be read",
                              f"{type(err).__name__}: {err}")
    else:
        if playback.engine_error or not playback.times:
            png = _message_figure(facts, "esmini could not play the scenario",
                                  playback.engine_error or "esmini recorded no step",
                                  playback.log[-6:])
        else:
            try:
                png = _replay_figure(playback, facts, map_path or facts.map_path)
            except (KeyError, IndexError, ValueError, TypeError) as err:  # a malformed playback
                png = _message_figure(facts, "the replay could not be drawn",
                                      f"{type(err).__name__}: {err}")
    out = folder / FIGURE_NAME
    write_bytes_atomic(out, _with_text(png, SOURCE_KEY, figure_source(folder, facts.status)))
    return out


def is_reported(outcome: dict, index: int) -> bool:
    """Whether a scenario's figure is one a run's report will show, so the worker that made
    the scenario draws it (in parallel) instead of the report at the end: every failed replay,
    and the first scenario of each class (``index`` 0), the one shown when it passes."""
    replay = outcome.get("replay")
    return bool(replay) and (not replay.get("passed") or index == 0)


def figure_source(folder: Path, status: dict) -> str:
    """What a figure of ``folder`` shows, as a digest: the playback and the verdict on it."""
    replay = status.get("replay") if isinstance(status.get("replay"), dict) else {}
    verdict = {"passed": replay.get("passed"), "codes": replay.get("codes"),
               "errors": (status.get("validation") or {}).get("errors")}
    try:
        played = json.loads((folder / REPLAY_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        played = None
    if isinstance(played, dict):  # how long the replay took is no part of what it shows
        played = {k: v for k, v in played.items() if k != "timings_s"}
    shown = json.dumps([played, verdict], sort_keys=True, default=str).encode()
    return hashlib.sha256(shown).hexdigest()


def is_current(folder: Path, status: dict) -> bool:
    """True when the folder's ``replay.png`` was drawn from its present replay and verdict."""
    try:
        drawn = _read_text(folder / FIGURE_NAME, SOURCE_KEY)
    except OSError:
        return False
    return drawn == figure_source(folder, status)


def _with_text(png: bytes, key: str, value: str) -> bytes:
    """``png`` with a ``tEXt`` chunk ``key: value`` right after its header chunk."""
    data = key.encode("latin-1") + b"\0" + value.encode("latin-1")
    chunk = (struct.pack(">I", len(data)) + b"tEXt" + data
             + struct.pack(">I", zlib.crc32(b"tEXt" + data)))
    header_end = 8 + 8 + 13 + 4  # signature, IHDR's length+type, its 13 bytes, its CRC
    return png[:header_end] + chunk + png[header_end:]


def _read_text(path: Path, key: str) -> str | None:
    """The value of the ``tEXt`` chunk ``key`` before the image data, or None."""
    with open(path, "rb") as handle:
        head = handle.read(4096)
    at = 8
    while at + 8 <= len(head):
        length, kind = struct.unpack(">I4s", head[at:at + 8])
        if kind == b"IDAT":
            break
        if kind == b"tEXt":
            name, _, value = head[at + 8:at + 8 + length].partition(b"\0")
            if name == key.encode("latin-1"):
                return value.decode("latin-1")
        at += 12 + length
    return None


# --- what the folder says --------------------------------------------------------------------

class _Facts:
    """The record's values (params), the replay's verdict (status) and the scenario's
    storyboard (for the scripted speed changes), each possibly missing."""

    def __init__(self, folder: Path, params: dict, status: dict, doc: Any):
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

    @property
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

def _new_figure() -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=FIGURE_IN, dpi=DPI)
    FigureCanvasAgg(figure)
    return figure


def _png(figure: Any) -> bytes:
    """The figure as a palette PNG: a chart has few colours, and PNG_COLOURS of them make the
    file a fifth of a true-colour one (for the report's inline copies) at ~15 ms."""
    from PIL import Image

    figure.canvas.draw()
    pixels = np.asarray(figure.canvas.buffer_rgba())[..., :3]
    image = Image.fromarray(pixels).quantize(colors=PNG_COLOURS,
                                             method=Image.Quantize.FASTOCTREE)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _title(figure: Any, facts: _Facts) -> None:
    verdict, colour = facts.verdict()
    figure.suptitle(f"{facts.scenario_id} · {facts.maneuver_class} · {verdict}", fontsize=10,
                    color=colour, x=0.01, ha="left", y=0.985)


def _message_figure(facts: _Facts, headline: str, detail: str,
                    log: list[str] | None = None) -> bytes:
    figure = _new_figure()
    _title(figure, facts)
    lines = [headline, "", *textwrap.wrap(detail, 110)[:8]]
    if log:
        lines += ["", "esmini's last log lines:", *(textwrap.shorten(line, 120) for line in log)]
    figure.text(0.04, 0.88, "\n".join(lines), va="top", ha="left", fontsize=9,
                family="monospace", color=FAIL_COLOUR if facts.replay else "black")
    return _png(figure)


def _replay_figure(playback: Playback, facts: _Facts, map_path: Any) -> bytes:
    figure = _new_figure()
    grid = figure.add_gridspec(2, 2, width_ratios=(1.25, 1.0), left=0.065, right=0.985,
                               top=0.905, bottom=0.2, hspace=0.12, wspace=0.17)
    speed_axes = figure.add_subplot(grid[0, 0])
    lower_axes = figure.add_subplot(grid[1, 0], sharex=speed_axes)
    map_axes = figure.add_subplot(grid[:, 1])
    colours = _colours(playback)
    _speed_panel(speed_axes, playback, facts, colours)
    if facts.params.get("domain") == "urban":
        _urban_panel(lower_axes, playback, facts, colours, map_path)
    else:
        _gap_panel(lower_axes, playback, facts, colours, map_path)
    for axes in (speed_axes, lower_axes):
        for time_s in _first_collisions(playback):
            axes.axvline(time_s, color=FAIL_COLOUR, linestyle=":", linewidth=1.0)
        axes.grid(alpha=0.3, linewidth=0.5)
        axes.tick_params(labelsize=7)
        axes.set_xlim(0.0, max(playback.duration_s, 0.1))
    speed_axes.tick_params(labelbottom=False)
    lower_axes.set_xlabel("time (s)", fontsize=8)
    _map_panel(map_axes, playback, facts, colours, map_path)
    _title(figure, facts)
    _caption(figure, facts, playback.series_errors)
    return _png(figure)


def _colours(playback: Playback) -> dict[str, str]:
    others = [e for e in playback.entities if e != EGO]
    colours = {name: OTHER_COLOURS[i % len(OTHER_COLOURS)] for i, name in enumerate(others)}
    colours[EGO] = EGO_COLOUR
    return colours


def _caption(figure: Any, facts: _Facts, series_errors: dict | None = None) -> None:
    findings = facts.findings()
    if not findings:
        text = ("replay as recorded: no REPLAY_* finding" if facts.replay and
                facts.replay.get("passed") else "")
    else:
        shown = [textwrap.shorten(line, 150, placeholder=" …") for line in
                 findings[:MAX_CAPTION_LINES]]
        if len(findings) > MAX_CAPTION_LINES:
            shown[-1] = f"… and {len(findings) - MAX_CAPTION_LINES + 1} more findings " \
                        "(status.json)"
        text = "\n".join(shown)
    if series_errors:  # the whole record, sample by sample (judge.replay)
        text += ("\n" if text else "") + "against the recorded series: " + "; ".join(
            f"{name} max {e['max']:.2f} / RMS {e['rms']:.2f}" for name, e in series_errors.items())
    figure.text(0.01, 0.1, text, va="top", ha="left", fontsize=7.5,
                color=FAIL_COLOUR if findings else PASS_COLOUR)


def _first_collisions(playback: Playback) -> list[float]:
    """The time each colliding pair first touches."""
    first: dict[tuple[str, str], float] = {}
    for time_s, a, b in playback.collisions:
        first.setdefault((a, b), float(time_s))
    return sorted(set(first.values()))


# --- speed -----------------------------------------------------------------------------------

def _speed_panel(axes: Any, playback: Playback, facts: _Facts, colours: dict[str, str]) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from scenweave.judge.fidelity import placed_actors

    start, duration = facts.number("maneuver_start_s"), facts.number("duration_s")
    handles = []
    if start is not None and duration is not None:
        axes.axvspan(start, start + duration, color="#888888", alpha=0.13, linewidth=0)
        handles.append(Patch(color="#888888", alpha=0.3, label="manoeuvre (record)"))
    for name in playback.entities:
        axes.plot(playback.times, playback.tracks[name]["speed"], color=colours[name],
                  linewidth=1.3)
        handles.append(Line2D([], [], color=colours[name], label=name))
    handles += _recorded_lines(axes, facts, colours, "speed_ms", lambda v: v)
    for name, prefix in placed_actors(facts.params):
        value = facts.number(f"{prefix}_speed_ms")
        if value is not None and name in colours:
            axes.errorbar(0.0, value, yerr=SPEED_TOL_MS, fmt="o", markersize=5,
                          markerfacecolor="white", color=colours[name], capsize=2, zorder=5,
                          clip_on=False)
    for name, target, at_s in _speed_targets(facts):
        if name in colours:
            axes.errorbar(at_s, target, yerr=SPEED_TOL_MS, fmt="D", markersize=5,
                          markerfacecolor="white", color=colours[name], capsize=2, zorder=5)
    handles += [Line2D([], [], marker="o", linestyle="", color="black", markerfacecolor="white",
                       label="record: start speed"),
                Line2D([], [], marker="D", linestyle="", color="black", markerfacecolor="white",
                       label="record: target speed")]
    axes.set_ylabel("speed (m/s)", fontsize=8)
    axes.legend(handles=handles, fontsize=6.5, loc="best", ncol=2, framealpha=0.8)


def _speed_targets(facts: _Facts) -> list[tuple[str, float, float]]:
    """(entity, target speed, when it should be reached) of every scripted speed change."""
    from scenweave.judge.fidelity import expected_speed_changes

    changes = []
    if facts.doc is not None:
        try:
            changes = expected_speed_changes(facts.doc, facts.params)
        except (KeyError, TypeError, ValueError, AttributeError):
            changes = []
    elif facts.number("ego_end_speed_ms") is not None:
        changes = [("hero_speed_change", facts.number("ego_end_speed_ms"),
                    facts.number("duration_s"), facts.number("maneuver_start_s"))]
    found = []
    for name, target, duration, start in changes:
        values = [target, duration, start]
        if all(isinstance(v, int | float) and math.isfinite(v) for v in values):
            found.append((name.removesuffix("_speed_change"), float(target),
                          float(start) + float(duration)))
    return found


def _recorded_lines(axes: Any, facts: _Facts, colours: dict[str, str], what: str,
                    convert: Any) -> list[Any]:
    """The mined record's own series, dashed, beside the replay's curves (``what``: speed_ms
    or gap_m; ``convert`` turns recorded values into the panel's)."""
    from matplotlib.lines import Line2D

    drawn = []
    for role, entity in (("ego", EGO), ("npc", "npc")):
        curve = facts.recorded_curve(f"{role}_{what}")
        if curve is not None and entity in colours:
            axes.plot(curve[0], convert(curve[1]), color=colours[entity], linewidth=1.1,
                      linestyle="--")
            drawn.append(entity)
    if not drawn:
        return []
    return [Line2D([], [], color="black", linestyle="--", label="recorded (mined data)")]


# --- gap (highway) ---------------------------------------------------------------------------

def _sample_times(playback: Playback, series: int, marked: list[float]) -> list[float]:
    """Every GAP_STEP_S (coarser when ``series`` curves would need too many measurements),
    and the marked times themselves so the record's values meet a measured point."""
    span = playback.duration_s
    step = max(GAP_STEP_S, span * max(1, series) / MAX_GAP_SAMPLES)
    times = np.arange(0.0, span + 1e-9, step).tolist()
    if times[-1] < span - 1e-6:
        times.append(span)
    return sorted(set(times) | {t for t in marked if 0.0 <= t <= span})


def _gaps(playback: Playback, entity: str, times: list[float], map_path: Any) -> list[float]:
    gaps = []
    for time_s in times:
        try:
            gap = gap_along_lane(playback, entity, time_s, map_path)
        except Exception:  # noqa: BLE001 - a picture shows what it can measure
            gap = None
        gaps.append(math.nan if gap is None else gap)
    return gaps


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


def _gap_panel(axes: Any, playback: Playback, facts: _Facts, colours: dict[str, str],
               map_path: Any) -> None:
    others = [e for e in playback.entities if e != EGO]
    if not others:
        axes.text(0.5, 0.5, "no other vehicle: no gap to show", transform=axes.transAxes,
                  ha="center", va="center", fontsize=8, color="#57606a")
        axes.set_ylabel("gap (m)", fontsize=8)
        return
    recorded = _recorded_gaps(facts)
    times = _sample_times(playback, len(others), [t for _, _, t in recorded])
    kind = facts.params.get("npc_vehicle_type")
    mined = _recorded_lines(axes, facts, colours, "gap_m",
                            np.vectorize(lambda g: reference_gap_m(g, kind), otypes=[float]))
    for name in others:
        axes.plot(times, _gaps(playback, name, times, map_path), color=colours[name],
                  linewidth=1.3, label=name)
    for name, gap, at_s in recorded:
        if name in colours:
            axes.errorbar(at_s, gap, yerr=GAP_TOL_M, fmt="D", markersize=5,
                          markerfacecolor="white", color=colours[name], capsize=2, zorder=5)
    axes.axhline(0.0, color="black", linewidth=0.6)
    axes.set_ylabel("gap to ego along lane (m)", fontsize=8)
    from matplotlib.lines import Line2D

    handles, _ = axes.get_legend_handles_labels()
    handles.append(Line2D([], [], marker="D", linestyle="", color="black",
                          markerfacecolor="white", label="record: gap"))
    handles += mined
    axes.legend(handles=handles, fontsize=6.5, loc="best", framealpha=0.8)


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


def _lead_line(axes: Any, playback: Playback, facts: _Facts, colour: str, map_path: Any) -> None:
    """Where the lead is, counted from the ego's start like the ego's distance: its replayed
    gap at t = 0 plus what it drove (one lane measurement, not one per sample: in town the
    lanes branch and a gap that cannot be followed costs a long search)."""
    gap = _gaps(playback, "lead", [0.0], map_path)[0]
    if math.isfinite(gap):
        axes.plot(playback.times, gap + _driven(playback, "lead"), color=colour, linewidth=1.2,
                  linestyle="-.", label="lead: gap at start + distance driven")
    recorded = facts.number("lead_distance_m")
    if recorded is not None:
        axes.errorbar(0.0, recorded, yerr=GAP_TOL_M, fmt="D", markersize=5,
                      markerfacecolor="white", color=colour, capsize=2, zorder=5,
                      clip_on=False, label="record: lead gap")


def _urban_panel(axes: Any, playback: Playback, facts: _Facts, colours: dict[str, str],
                 map_path: Any) -> None:
    for begin, end, colour in _light_spans(playback):
        axes.axvspan(begin, end, color=LIGHT_COLOURS.get(colour, "#cccccc"), alpha=0.15,
                     linewidth=0)
    axes.plot(playback.times, _driven(playback, EGO), color=colours[EGO], linewidth=1.3,
              label="ego: distance driven")
    stop_line = facts.number("spawn_stop_line_distance_m")
    if stop_line is not None:
        axes.axhline(stop_line, color="black", linestyle="--", linewidth=0.9,
                     label=f"stop line (record, {stop_line:.1f} m)")
    if "lead" in playback.tracks:
        _lead_line(axes, playback, facts, colours["lead"], map_path)
    axes.set_ylabel("metres", fontsize=8)
    axes.legend(fontsize=6.5, loc="best", framealpha=0.8)


# --- bird's-eye view -------------------------------------------------------------------------

def _map_panel(axes: Any, playback: Playback, facts: _Facts, colours: dict[str, str],
               map_path: Any) -> None:
    points = np.array([(x, y) for name in playback.entities
                       for x, y in zip(playback.tracks[name]["x"], playback.tracks[name]["y"],
                                       strict=False)
                       if math.isfinite(x) and math.isfinite(y)])
    turn_exit = (facts.number("turn_exit_x"), facts.number("turn_exit_y"))
    extra = [turn_exit] if None not in turn_exit else []
    if not len(points):
        axes.text(0.5, 0.5, "no position recorded", transform=axes.transAxes, ha="center")
        return
    every = np.vstack([points, np.array(extra).reshape(-1, 2)])
    low, high = every.min(axis=0) - MAP_MARGIN_M, every.max(axis=0) + MAP_MARGIN_M
    _draw_lanes(axes, map_path, (low[0], high[0], low[1], high[1]))
    for name in playback.entities:
        track = playback.tracks[name]
        ego = name == EGO  # on top, thinner: a follower's path often lies on the ego's
        axes.plot(track["x"], track["y"], color=colours[name], linewidth=1.4 if ego else 2.8,
                  alpha=1.0 if ego else 0.75, zorder=3 if ego else 2)
        axes.plot(track["x"][0], track["y"][0], marker="o", markersize=5, color=colours[name],
                  markeredgecolor="black", markeredgewidth=0.5, zorder=4)
        axes.plot(track["x"][-1], track["y"][-1], marker="s", markersize=4,
                  markerfacecolor="white", color=colours[name], zorder=4)
    if extra:
        axes.plot(*turn_exit, marker="*", markersize=10, color="black", linestyle="", zorder=5,
                  label="record: turn exit")
    _mark_stop_line(axes, playback, facts)
    light = (facts.number("tfl_x_carla"), facts.number("tfl_y_carla"))
    if None not in light:  # CARLA's y points the other way
        axes.plot(light[0], -light[1], marker="s", markersize=6, color="#ff9900",
                  markeredgecolor="black", markeredgewidth=0.5, linestyle="", zorder=5,
                  label="traffic light")
    _equal_limits(axes, low, high)
    _mark_collisions(axes, playback)
    axes.tick_params(labelsize=7)
    axes.set_xlabel("x (m, OpenDRIVE)", fontsize=8)
    axes.set_ylabel("y (m)", fontsize=8, labelpad=1)
    axes.set_title("paths: start ● end ■, collision ✕", fontsize=8)
    if axes.get_legend_handles_labels()[0]:
        axes.legend(fontsize=6.5, loc="best", framealpha=0.8)


def _equal_limits(axes: Any, low: np.ndarray, high: np.ndarray) -> None:
    """Limits around ``low``..``high`` with one metre as long across as up, filling the axes."""
    box = axes.get_position()
    width_in, height_in = axes.figure.get_size_inches()
    ratio = (box.height * height_in) / (box.width * width_in)  # axes height / width
    centre, span = (low + high) / 2, high - low
    span = np.array([max(span[0], span[1] / ratio), max(span[1], span[0] * ratio)])
    axes.set_xlim(centre[0] - span[0] / 2, centre[0] + span[0] / 2)
    axes.set_ylim(centre[1] - span[1] / 2, centre[1] + span[1] / 2)
    axes.set_aspect("equal", adjustable="box")


def _mark_collisions(axes: Any, playback: Playback) -> None:
    seen: set[tuple[str, str]] = set()
    for time_s, a, b in playback.collisions:
        if (a, b) in seen or a not in playback.tracks or b not in playback.tracks:
            continue
        seen.add((a, b))
        x = (playback.value(a, "x", time_s) + playback.value(b, "x", time_s)) / 2
        y = (playback.value(a, "y", time_s) + playback.value(b, "y", time_s)) / 2
        axes.plot(x, y, marker="X", markersize=11, color=FAIL_COLOUR, markeredgecolor="white",
                  markeredgewidth=0.8, zorder=6)
        left = x > sum(axes.get_xlim()) / 2  # the label toward the middle, not off the edge
        axes.annotate(f"{a}–{b} {float(time_s):.2f} s", (x, y), textcoords="offset points",
                      xytext=(-7 if left else 7, 6), ha="right" if left else "left",
                      fontsize=7, color=FAIL_COLOUR, zorder=6,
                      bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                            "alpha": 0.8})


def _mark_stop_line(axes: Any, playback: Playback, facts: _Facts) -> None:
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
    axes.plot([x - half * math.sin(h), x + half * math.sin(h)],
              [y + half * math.cos(h), y - half * math.cos(h)], color="black", linewidth=2.2,
              zorder=5, label="record: stop line")


def _draw_lanes(axes: Any, map_path: Any, box: tuple[float, float, float, float]) -> None:
    """Every drivable lane's borders that come into ``box`` (x0, x1, y0, y1)."""
    from matplotlib.collections import LineCollection

    try:
        lanes = _lane_borders(_network(map_path))
    except Exception:  # noqa: BLE001 - without the map the paths are still worth a look
        return
    x0, x1, y0, y1 = box
    for in_junction, colour, width in ((False, "#9a9a9a", 0.6), (True, "#cfcfcf", 0.5)):
        chosen = [line for bounds, junction, line in lanes if junction == in_junction
                  and bounds[0] <= x1 and bounds[1] >= x0 and bounds[2] <= y1 and bounds[3] >= y0]
        if chosen:
            axes.add_collection(LineCollection(chosen, colors=colour, linewidths=width,
                                               zorder=1))


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

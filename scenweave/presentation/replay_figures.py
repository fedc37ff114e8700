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
chart primitives of ``charts`` and ``plot`` (scales, ticks at nice numbers, lines as SVG
path data, marks, legends); what the folder says is ``replay_facts``, the panels
``replay_panels``. ``templates/replay_figure.svg`` (which extends ``chart.svg``) draws it
(Jinja2, every value escaped: a record's text is shown, never run).
"""

from __future__ import annotations

import hashlib
import json
import re
import textwrap
from pathlib import Path
from typing import Any

from scenweave.files.atomic import write_text_atomic
from scenweave.player import Playback
from scenweave.presentation.charts import (
    CAPTION_PX,
    DOTTED,
    TITLE_PX,
    Chart,
    Text,
    render_svg,
)
from scenweave.presentation.plot import Plot
from scenweave.presentation.replay_facts import (
    EGO,
    EGO_COLOUR,
    FAIL_COLOUR,
    OTHER_COLOURS,
    PASS_COLOUR,
    ReplayFacts,
)
from scenweave.presentation.replay_panels import (
    LOWER_FRAME,
    SPEED_FRAME,
    gap_panel,
    map_panel,
    speed_panel,
    urban_panel,
)
from scenweave.schemas.scenario_folder import (
    FIGURE_NAME,
    REPLAY_NAME,
    ReplayVerdict,
    read_verdict,
)

TEMPLATE = "replay_figure.svg"
#: the figure's size in pixels, the same for every replay
FIGURE_PX = (900, 504)
#: the namespace of the ``<metadata>`` element naming what the figure shows (``figure_source``)
SOURCE_NS = "urn:scenweave:replay-figure"
_SOURCE_PATTERN = re.compile(r"<sw:source[^>]*>([0-9a-f]{64})</sw:source>")
#: at most this many findings are listed under the plots
MAX_CAPTION_LINES = 4
CAPTION_TOP = 446.0


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
    facts = ReplayFacts.read(folder)
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
                                      source=_source_of(played, facts.status, facts.judged),
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
    return _source_of(_read_playback(folder / REPLAY_NAME)[0], status, read_verdict(folder))


def is_current(folder: Path, status: dict) -> bool:
    """True when the folder's ``replay.svg`` was drawn from its present replay and verdict."""
    try:
        with open(folder / FIGURE_NAME, encoding="utf-8", errors="replace") as handle:
            head = handle.read(4096)
    except OSError:
        return False
    drawn = _SOURCE_PATTERN.search(head)
    return drawn is not None and drawn.group(1) == figure_source(folder, status)


def _read_playback(path: Path) -> tuple[Any, Playback | Exception]:
    """``replay.json`` as read (None when it cannot be) and its playback, or why there is
    none; read once for the figure and for what it shows."""
    played = None
    try:
        played = json.loads(path.read_text(encoding="utf-8"))
        return played, Playback.from_dict(played)
    except (OSError, ValueError, TypeError, KeyError, AttributeError) as err:
        return played, err


def _source_of(played: Any, status: dict, judged: ReplayVerdict | None) -> str:
    raw = status.get("replay")
    replay: dict[str, Any] = raw if isinstance(raw, dict) else {}
    verdict = {"passed": replay.get("passed"), "codes": replay.get("codes"),
               "errors": (status.get("validation") or {}).get("errors")}
    if isinstance(played, dict):  # how long the replay took is no part of what it shows
        played = {k: v for k, v in played.items() if k != "timings_s"}
    shown = json.dumps([played, verdict, judged], sort_keys=True, default=str).encode()
    return hashlib.sha256(shown).hexdigest()


# --- the figure ------------------------------------------------------------------------------

def _title(facts: ReplayFacts) -> Text:
    verdict, colour = facts.verdict()
    return Text(9, 19, f"{facts.scenario_id} · {facts.maneuver_class} · {verdict}", TITLE_PX,
                colour, cls="title")


def _message_figure(facts: ReplayFacts, headline: str, detail: str,
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


def _replay_figure(playback: Playback, facts: ReplayFacts, map_path: Any) -> Chart:
    colours = _colours(playback)
    times = (0.0, max(playback.duration_s, 0.1))
    speed = Plot("speed", SPEED_FRAME)
    speed_panel(speed, playback, facts, colours)
    lower = Plot("lower", LOWER_FRAME)
    if facts.params.get("domain") == "urban":
        urban_panel(lower, playback, facts, colours, map_path)
        lower_label = "metres"
    else:
        gap_panel(lower, playback, facts, colours, map_path)
        lower_label = "gap to ego along lane (m)"
    for plot in (speed, lower):
        for time_s in _first_collisions(playback):
            plot.vline(time_s, FAIL_COLOUR, 1.25, DOTTED)
    title = _title(facts)
    return Chart(title.text, *FIGURE_PX, panels=[
        speed.finish(speed.auto_scales(times), x_labels=False, y_label="speed (m/s)"),
        lower.finish(lower.auto_scales(times), x_label="time (s)", y_label=lower_label),
        map_panel(playback, facts, colours, map_path),
    ], texts=[title, *_caption(facts, playback.series_errors)])


def _colours(playback: Playback) -> dict[str, str]:
    others = [e for e in playback.entities if e != EGO]
    colours = {name: OTHER_COLOURS[i % len(OTHER_COLOURS)] for i, name in enumerate(others)}
    colours[EGO] = EGO_COLOUR
    return colours


def _caption(facts: ReplayFacts, series_errors: dict | None = None) -> list[Text]:
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

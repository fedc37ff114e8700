"""The panels of a replay figure: each actor's speed, the gaps to the ego (highway), the
distance against the stop line (urban) and the bird's-eye view of the paths on the map.
"""


from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from scenweave.judge.replay import gap_series, lane_changes
from scenweave.player import Playback
from scenweave.presentation.charts import (
    DASH_DOT,
    DASHED,
    LABEL_PX,
    Panel,
    Scale,
    Stroke,
    Text,
    path_data,
)
from scenweave.presentation.plot import Entry, Plot
from scenweave.presentation.replay_facts import (
    EGO,
    FAIL_COLOUR,
    LIGHT_COLOURS,
    ReplayFacts,
)
from scenweave.scenario_lib.vehicles import reference_gap_m

#: the gap is measured along the lanes this often (s; each measurement ~1 ms), coarser when
#: a long replay with several vehicles would need more than MAX_GAP_ANCHORS of them, and at
#: the record's marked times; between two measurements it follows the distances driven
GAP_ANCHOR_S = 2.0
MAX_GAP_ANCHORS = 16
#: metres of map shown around the paths
MAP_MARGIN_M = 20.0
#: the panels' frames (x, y, width, height) in pixels
SPEED_FRAME = (58.0, 46.0, 422.0, 176.0)
LOWER_FRAME = (58.0, 234.0, 422.0, 166.0)
MAP_FRAME = (552.0, 46.0, 336.0, 354.0)
CAPTION_TOP = 446.0
#: the map's lanes keep one point per this many pixels: they bend gently at its scale (a
#: chord of 6 px misses a 20 px radius by 0.2 px)
LANE_THIN_PX = 6.0


# --- speed -----------------------------------------------------------------------------------

def speed_panel(plot: Plot, playback: Playback, facts: ReplayFacts,
                colours: dict[str, str]) -> None:
    start, duration = facts.number("maneuver_start_s"), facts.number("duration_s")
    if start is not None and duration is not None:
        plot.span(start, start + duration, "#888888", 0.13)
        plot.legend.append(Entry("manoeuvre (record)", "#888888", patch=True))
    for name in playback.entities:
        plot.line(playback.times, playback.tracks[name]["speed"], colours[name], 1.6)
        plot.legend.append(Entry(name, colours[name]))
    plot.legend += _recorded_lines(plot, facts, colours, "speed_ms", lambda v: v)
    for mark in facts.marks("speed_marks"):
        if mark["entity"] in colours:
            start_speed = mark["what"] == "start speed"
            plot.mark(mark["t"], mark["expected"], "circle" if start_speed else "diamond",
                      colours[mark["entity"]], 6.25, fill="white", tolerance=mark["tol"],
                      clip=not start_speed)
    plot.legend += [Entry("record: start speed", mark="circle"),
                    Entry("record: target speed", mark="diamond")]
    plot.legend_columns = 2


def _recorded_lines(plot: Plot, facts: ReplayFacts, colours: dict[str, str], what: str,
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
    times = playback.times
    found = []
    for name in {EGO, entity}:
        for time_s, _ in lane_changes(playback, name):
            i = playback.index_at(time_s)
            found += [times[max(i - 1, 0)], times[i]]
    return found


def _gaps(playback: Playback, entity: str, times: Sequence[float], map_path: Any) -> np.ndarray:
    return np.asarray([math.nan if gap is None else gap
                       for gap in gap_series(playback, entity, times, map_path)], dtype=float)


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


def gap_panel(plot: Plot, playback: Playback, facts: ReplayFacts, colours: dict[str, str],
               map_path: Any) -> None:
    others = [e for e in playback.entities if e != EGO]
    if not others:
        plot.note("no other vehicle: no gap to show")
        return
    recorded = facts.marks("gap_marks")
    anchors = _anchor_times(playback, len(others), [mark["t"] for mark in recorded])
    kind = facts.params.get("npc_vehicle_type")
    mined = _recorded_lines(plot, facts, colours, "gap_m",
                            np.vectorize(lambda g: reference_gap_m(g, kind), otypes=[float]))
    for name in others:
        at = sorted(set(anchors) | set(_lane_change_times(playback, name)))
        plot.line(*_gap_curve(playback, name, at, map_path), colours[name], 1.6)
        plot.legend.append(Entry(name, colours[name]))
    for mark in recorded:
        if mark["entity"] in colours:
            plot.mark(mark["t"], mark["expected"], "diamond", colours[mark["entity"]], 6.25,
                      fill="white", tolerance=mark["tol"])
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


def _lead_line(plot: Plot, playback: Playback, facts: ReplayFacts, colour: str,
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
        plot.mark(0.0, recorded, "diamond", colour, 6.25, fill="white",
                  tolerance=facts.tolerance("gap_m") or 0.0, clip=False)
        plot.legend.append(Entry("record: lead gap", colour, mark="diamond"))


def urban_panel(plot: Plot, playback: Playback, facts: ReplayFacts, colours: dict[str, str],
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

def map_panel(playback: Playback, facts: ReplayFacts, colours: dict[str, str],
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


def _mark_stop_line(plot: Plot, playback: Playback, facts: ReplayFacts) -> None:
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


def warm_lanes(map_path: Any) -> None:
    """Read ``map_path`` and sample its lanes' borders now, once per process, as the first
    figure drawn on it would: a batch does it before it forks its workers, which inherit both
    instead of each making them for its first figure."""
    _lane_borders(_network(map_path))


def _network(map_path: Any) -> Any:
    from scenweave import roads

    return roads.road_network(map_path)


@lru_cache(maxsize=4)
def _lane_borders(network: Any) -> list[tuple[tuple[float, float, float, float], bool,
                                              np.ndarray]]:
    """(x0, x1, y0, y1), in a junction, (n, 2) points of each border of every drivable lane,
    sampled every ~2 m along the road. Once per map."""
    return [(line.bounds, line.in_junction, line.points) for line in network.border_lines()]

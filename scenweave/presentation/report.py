"""What a run or a benchmark did, for a reader: metrics over outcomes, figures, ``report.html``.

Everything here works on outcome dicts (``status.json`` of each scenario, the ``scenarios`` of
``summary.json``), so it runs the same on a ``--no-llm`` run, an agent run and a benchmark.
The metrics follow thesis §6.1: success rate (SR, the LLM's own success: ``ok`` or
``repaired``), first-attempt rate, latency per scenario and the error taxonomy; a fallback
still delivers a scenario, so ``delivered_rate`` counts it too. The HTML page is static and
self-contained: figures are inline ``data:`` SVG images (the charts drawn with
``scenweave.charts``, the replay figures by ``replay_figures``), links are relative to the run
folder. It is rendered from ``templates/run_report.html`` (Jinja2, every value escaped); this
module only computes what the page and its charts show.
"""

from __future__ import annotations

import base64
import json
import math
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import markupsafe

from scenweave.charts import (
    SERIES_COLOURS,
    Chart,
    Entry,
    Panel,
    Plot,
    category_label_depth,
    padded,
    render_svg,
)
from scenweave.files.atomic import write_text_atomic
from scenweave.run_folder import RUN_FILE, STATUS_FILE, STATUSES, SUMMARY_FILE, safe_name
from scenweave.templating import render, templates

REPORT_FILE = "report.html"
REPLAY_JSON, REPLAY_FIGURE = "replay.json", "replay.svg"
SCENARIO_FILES = ("scenario.xosc", "scenario.py", "trace.jsonl", "params.json", STATUS_FILE,
                  REPLAY_JSON, REPLAY_FIGURE)
HOUR_S = 3600.0
#: replay figures embedded in a run's report: every failed replay, up to this many passing
#: ones per class, at most this many in all
REPLAY_PASSING_PER_CLASS = 1
REPLAY_FIGURES_MAX = 40


# --- metrics -------------------------------------------------------------------------------

def latency_s(outcome: dict) -> float | None:
    """Wall-clock seconds one scenario took (``timings_s.total``), or None if unknown."""
    total = (outcome.get("timings_s") or {}).get("total")
    return float(total) if isinstance(total, int | float) else None


def percentile(values: list[float], q: float) -> float | None:
    """The ``q``-th percentile (0..100) by linear interpolation; None for no values."""
    if not values:
        return None
    ordered = sorted(values)
    rank = (len(ordered) - 1) * q / 100.0
    low, high = math.floor(rank), math.ceil(rank)
    return ordered[low] + (ordered[high] - ordered[low]) * (rank - low)


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 4)


def latency_stats(values: list[float]) -> dict:
    """Mean, standard deviation, p50, p95, min and max of latencies in seconds."""
    if not values:
        return {"mean": None, "std": None, "p50": None, "p95": None, "min": None, "max": None}
    mean = sum(values) / len(values)
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / len(values))
    return {"mean": round(mean, 4), "std": round(std, 4),
            "p50": _rounded(percentile(values, 50)), "p95": _rounded(percentile(values, 95)),
            "min": round(min(values), 4), "max": round(max(values), 4)}


def metrics(outcomes: list[dict]) -> dict:
    """Thesis §6.1 metrics over a group of outcomes (a run, a class, a model)."""
    n = len(outcomes)
    counts = Counter(o.get("status", "failed") for o in outcomes)
    latencies = [v for v in (latency_s(o) for o in outcomes) if v is not None]
    tokens_in = sum(int(o.get("tokens_in") or 0) for o in outcomes)
    tokens_out = sum(int(o.get("tokens_out") or 0) for o in outcomes)
    taxonomy = Counter(t for o in outcomes for t in o.get("error_taxonomy") or [])
    return {
        "n": n,
        "counts": {s: counts.get(s, 0) for s in STATUSES},
        "success_rate": _rate(counts["ok"] + counts["repaired"], n),
        "delivered_rate": _rate(n - counts["failed"], n),
        "first_attempt_rate": _rate(sum(bool(o.get("first_attempt_success"))
                                        for o in outcomes), n),
        "mean_attempts": round(sum(o.get("attempts") or 0 for o in outcomes) / n, 3) if n else None,
        "fallbacks": sum(bool(o.get("fallback")) for o in outcomes),
        "latency_s": latency_stats(latencies),
        "per_hour": scenarios_per_hour(latencies),
        "tokens_in": tokens_in, "tokens_out": tokens_out,
        "tokens_per_scenario": round((tokens_in + tokens_out) / n, 1) if n else None,
        "error_taxonomy": dict(sorted(taxonomy.items())),
        "errors_total": sum(taxonomy.values()),
    }


def by_class(outcomes: Iterable[dict]) -> dict[str, list[dict]]:
    """Outcomes grouped by manoeuvre class, classes sorted."""
    groups: dict[str, list[dict]] = {}
    for o in outcomes:
        groups.setdefault(o.get("maneuver_class", "?"), []).append(o)
    return dict(sorted(groups.items()))


def projected_curve(latencies: list[float], horizon_s: float = HOUR_S,
                    max_points: int = 2000) -> list[tuple[float, int]]:
    """(time, scenarios finished) of one sequential pipeline over ``horizon_s`` (Fig. 6.4).

    The observed latencies are repeated in order until the horizon, as if one pipeline
    instance kept running on the same mix of classes. At most ``max_points`` points are kept
    (every k-th scenario, and the last one), so a fast run does not make a million points.
    """
    usable = [v for v in latencies if v > 0]
    if not usable:
        return []
    expected = horizon_s / (sum(usable) / len(usable))
    step = max(1, math.ceil(expected / max_points))
    curve: list[tuple[float, int]] = []
    clock, count = 0.0, 0
    while True:
        for value in usable:
            if clock + value > horizon_s:
                if not curve or curve[-1][1] != count:
                    curve.append((clock, count))
                return curve
            clock += value
            count += 1
            if count % step == 0:
                curve.append((clock, count))


def scenarios_per_hour(latencies: list[float]) -> float | None:
    """Scenarios one sequential pipeline makes per hour at these latencies."""
    usable = [v for v in latencies if v > 0]
    return round(HOUR_S * len(usable) / sum(usable), 1) if usable else None


def observed_curve(run_dir: Path, outcomes: list[dict]) -> list[tuple[float, int]]:
    """(seconds since the run's first start, scenarios finished) at each commit, from the files.

    A scenario's ``status.json`` is written when it is committed, so its modification time
    is the finish time; the start of the run is the earliest finish minus its latency.
    """
    points = []
    for o in outcomes:
        path = Path(run_dir) / safe_name(o["scenario_id"]) / STATUS_FILE
        if path.exists():
            points.append((path.stat().st_mtime, latency_s(o) or 0.0))
    if not points:
        return []
    start = min(end - took for end, took in points)
    return [(t, n) for n, t in enumerate(sorted(end - start for end, _ in points), start=1)]


# --- figures (SVG, drawn by scenweave.charts) -----------------------------------------------

SVG = "image/svg+xml"
#: the charts' frame: pixels left of it (tick labels, axis name), above it, right of it; its
#: height; the width of one class (per series) in a chart by class, and the least width
CHART_LEFT, CHART_TOP, CHART_RIGHT, CHART_FRAME_HEIGHT = 62.0, 14.0, 16.0, 300.0
CLASS_PX, CHART_MIN_PX = 55.0, 640.0
#: below the frame of a chart with numbers on its x axis (tick labels and the axis name)
NUMBERS_BELOW_PX = 40.0
BOX_WIDTH = 0.5
MEDIAN_COLOUR = "#ff7f0e"


@dataclass(frozen=True)
class BoxStats:
    """What a box of a box plot shows: the quartiles, the whiskers (the furthest values within
    1.5 interquartile ranges of the box) and the values beyond them."""

    q1: float
    median: float
    q3: float
    low: float
    high: float
    fliers: list[float]


def box_stats(values: list[float], reach: float = 1.5) -> BoxStats:
    """The box of ``values`` (at least one), quartiles as ``percentile`` computes them."""
    if not values:
        raise ValueError("a box of no values")
    q1, median, q3 = (cast(float, percentile(values, q)) for q in (25, 50, 75))
    iqr = q3 - q1
    inside = [v for v in values if q1 - reach * iqr <= v <= q3 + reach * iqr]
    return BoxStats(q1, median, q3, min(inside), max(inside),
                    sorted(v for v in values if v < min(inside) or v > max(inside)))


def _frame(width: float) -> tuple[float, float, float, float]:
    return (CHART_LEFT, CHART_TOP, width - CHART_LEFT - CHART_RIGHT, CHART_FRAME_HEIGHT)


def _svg_bytes(title: str, width: float, below: float, panel: Panel) -> bytes:
    """One panel as an SVG document of ``width`` px, ``below`` px under its frame."""
    height = CHART_TOP + CHART_FRAME_HEIGHT + below
    return render_svg(Chart(title, round(width), round(height), [panel])).encode("utf-8")


def _by_class_layout(classes: list[str], per_class: int) -> tuple[float, float]:
    """(width, pixels below the frame) of a chart with one column of ``per_class`` per class."""
    width = max(CHART_MIN_PX, CLASS_PX * len(classes) * max(1, per_class) + CHART_LEFT
                + CHART_RIGHT)
    return width, category_label_depth(classes) + 8


def _class_ticks(classes: list[str]) -> list[tuple[float, str]]:
    return list(enumerate(classes))


def plot_latency_vs_success(per_model: dict[str, dict]) -> bytes:
    """Fig. 6.1: mean latency against success rate, one labelled point per model."""
    plot = Plot("latency-vs-success", _frame(CHART_MIN_PX))
    for i, (model, m) in enumerate(per_model.items()):
        mean, rate = m["latency_s"]["mean"] or 0.0, 100 * (m["success_rate"] or 0.0)
        plot.mark(mean, rate, "circle", SERIES_COLOURS[i % len(SERIES_COLOURS)], 8.0,
                  group=("model", model), cls="point")
        plot.annotate(mean, rate, model, cls="model")
    means = [m["latency_s"]["mean"] or 0.0 for m in per_model.values()]
    panel = plot.finish(plot.auto_scales(padded(means, 0.1), (-5.0, 105.0)),
                        x_label="mean latency (s/scenario)", y_label="success rate (%)")
    return _svg_bytes("Latency vs success rate per model", CHART_MIN_PX, NUMBERS_BELOW_PX, panel)


def plot_latency_per_class(series: dict[str, list[dict]]) -> bytes:
    """Fig. 6.2: mean latency ± standard deviation per class, one bar group per series."""
    classes = sorted({o.get("maneuver_class", "?") for group in series.values() for o in group})
    width, below = _by_class_layout(classes, len(series))
    plot = Plot("latency-per-class", _frame(width))
    bar = 0.8 / max(1, len(series))
    for i, (name, group) in enumerate(series.items()):
        colour = SERIES_COLOURS[i % len(SERIES_COLOURS)]
        grouped = by_class(group)
        for k, code in enumerate(classes):
            stats = latency_stats([v for v in map(latency_s, grouped.get(code, []))
                                   if v is not None])
            mean, std = stats["mean"] or 0.0, stats["std"] or 0.0
            left, shown = k - 0.4 + i * bar, ("bar", f"{name} {code}: {mean:.2f} ± {std:.2f} s")
            plot.rect(left, left + bar, 0.0, mean, colour, group=shown, cls="mean")
            if std:
                plot.error_bar(left + bar / 2, mean - std, mean + std, "black", group=shown,
                               cls="error-bar")
        if len(series) > 1:
            plot.legend.append(Entry(name, colour, patch=True, opacity=1.0))
    low, high = min([0.0, *plot.y_values]), max([0.0, *plot.y_values])
    scales = plot.auto_scales((-0.6, len(classes) - 0.4), (low, high * 1.05 or 1.0))
    panel = plot.finish(scales, y_label="latency (s/scenario)", grid="y",
                        categories=_class_ticks(classes))
    return _svg_bytes("Mean latency ± standard deviation per class", width, below, panel)


def plot_latency_boxplot(outcomes: list[dict]) -> bytes:
    """Fig. 6.3: the distribution of latencies per class: a box from the first to the third
    quartile with the median across it, whiskers to the furthest values within 1.5
    interquartile ranges, the values beyond as circles."""
    grouped = by_class(outcomes)
    classes = list(grouped)
    width, below = _by_class_layout(classes, 1)
    plot = Plot("latency-boxplot", _frame(width))
    half, cap = BOX_WIDTH / 2, BOX_WIDTH / 4
    for k, (code, group) in enumerate(grouped.items()):
        box = box_stats([v for v in map(latency_s, group) if v is not None] or [0.0])
        shown = ("box", code)
        plot.rect(k - half, k + half, box.q1, box.q3, "none", "black", 1.0, group=shown,
                  cls="quartiles")
        plot.segment(k - half, box.median, k + half, box.median, MEDIAN_COLOUR, 1.5,
                     group=shown, cls="median")
        for end, edge in ((box.low, box.q1), (box.high, box.q3)):
            plot.segment(k, edge, k, end, "black", 1.0, group=shown, cls="whisker")
            plot.segment(k - cap, end, k + cap, end, "black", 1.0, group=shown, cls="cap")
        for value in box.fliers:
            plot.mark(k, value, "circle", "black", 5.0, fill="none", edge_width=0.8,
                      group=shown, cls="flier")
    scales = plot.auto_scales((-0.6, len(classes) - 0.4))
    panel = plot.finish(scales, y_label="latency (s/scenario)", grid="y",
                        categories=_class_ticks(classes))
    return _svg_bytes("Distribution of latencies per class", width, below, panel)


def plot_cumulative(series: dict[str, list[tuple[float, int]]]) -> bytes:
    """Fig. 6.4: cumulative scenarios over time, one step curve per series of (time, count)."""
    plot = Plot("cumulative", _frame(CHART_MIN_PX))
    drawn = [(name, curve) for name, curve in series.items() if curve]
    for i, (name, curve) in enumerate(drawn):
        colour = SERIES_COLOURS[i % len(SERIES_COLOURS)]
        plot.step([0.0] + [t / 60 for t, _ in curve], [0] + [n for _, n in curve], colour, 1.5,
                  group=("series", name), cls="curve")
        plot.legend.append(Entry(f"{name}: {curve[-1][1]} in {curve[-1][0] / 60:.1f} min",
                                 colour))
    if not drawn:
        plot.note("no scenario finished")
    panel = plot.finish(plot.auto_scales(), x_label="time (min)", y_label="scenarios finished")
    return _svg_bytes("Cumulative scenarios over time", CHART_MIN_PX, NUMBERS_BELOW_PX, panel)


# --- the data the templates show -----------------------------------------------------------

def _rate(part: int, whole: int) -> float | None:
    return round(part / whole, 4) if whole else None


def pct(value: float | None) -> str:
    """A rate as a whole percentage, ``–`` for none."""
    return "–" if value is None else f"{100 * value:.0f}%"


def _sec(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


@dataclass(frozen=True)
class Table:
    """What a table of a report shows (``table`` in templates/macros.html draws it): the first
    ``text_columns`` columns are left-aligned text, ``column_classes`` adds a class to the
    cells of a column, ``row_classes`` one to each row."""

    header: list[str]
    rows: list[list[Any]]
    text_columns: int = 1
    column_classes: dict[int, str] = field(default_factory=dict)
    row_classes: list[str] | None = None

    @property
    def cell_classes(self) -> list[str]:
        """The class attribute of each column's cells, empty for none."""
        return [" ".join([*(["text"] if i < self.text_columns else []),
                          *([self.column_classes[i]] if i in self.column_classes else [])])
                for i in range(len(self.header))]


@dataclass(frozen=True)
class Figure:
    """A picture shown inline (a ``data:`` URI, so the page stays one file; an SVG shown as an
    image runs no script), with its caption and alternative text."""

    image: bytes
    caption: str
    alt: str
    media_type: str = SVG

    @property
    def data_uri(self) -> str:
        return f"data:{self.media_type};base64,{base64.b64encode(self.image).decode('ascii')}"


def _macros() -> Any:
    return templates().get_template("macros.html").module


def table(header: list[str], rows: list[list[Any]], text_columns: int = 1,
          row_classes: list[str] | None = None,
          column_classes: dict[int, str] | None = None) -> str:
    """An HTML table (cells escaped), for pages that are not a template of their own."""
    return str(_macros().table(Table(header, rows, text_columns, column_classes or {},
                                     row_classes)))


def figure(image: bytes, caption: str, alt: str, media_type: str = SVG) -> str:
    """An inline figure with a caption, for pages that are not a template of their own."""
    return str(_macros().figure(Figure(image, caption, alt, media_type)))


def page(title: str, body: str) -> str:
    """The report page around ``body``, HTML made by the caller from ``table`` and ``figure``
    (``bench.html``); the reports of a run and of mining are templates of their own."""
    return render("report.html", title=title, body=markupsafe.Markup(body))


def metrics_row(name: str, m: dict) -> list[Any]:
    """One row of the per-class / per-model metrics tables."""
    lat = m["latency_s"]
    return [name, m["n"], *(m["counts"][s] for s in STATUSES), pct(m["success_rate"]),
            pct(m["delivered_rate"]), pct(m["first_attempt_rate"]), _sec(lat["mean"]),
            _sec(lat["p50"]), _sec(lat["p95"]),
            "–" if m["per_hour"] is None else f"{m['per_hour']:.0f}",
            m["tokens_in"] + m["tokens_out"]]


METRICS_HEADER = ["", "n", *STATUSES, "SR", "delivered", "1st attempt", "mean s", "p50 s",
                  "p95 s", "per hour", "tokens"]


def count_boxes(counts: dict[str, int], total: int) -> list[tuple[int, str, str]]:
    """The outcome counts shown as big numbers: (number, label, class)."""
    return [(total, "scenarios", "total")] + [(counts.get(s, 0), s, s) for s in STATUSES]


def scenario_links(scenario_id: str, run_dir: Path) -> list[tuple[str, str]]:
    """(href, text) of relative links to a scenario's folder and the files in it that exist."""
    folder = safe_name(scenario_id)
    return [(f"{folder}/", "folder")] + [(f"{folder}/{name}", name) for name in SCENARIO_FILES
                                         if (run_dir / folder / name).exists()]


def render_run_report(run_dir: Path) -> str:
    """The HTML report of one run folder (reads ``summary.json``, ``run.json``, the folders)."""
    return render("run_report.html", **run_report_context(Path(run_dir)))


def run_report_context(run_dir: Path) -> dict[str, Any]:
    """What ``templates/run_report.html`` shows of a run folder."""
    summary = _read_json(run_dir / SUMMARY_FILE) or {}
    run = _read_json(run_dir / RUN_FILE) or {}
    outcomes = summary.get("scenarios") or []
    m = metrics(outcomes)
    run_id = summary.get("run_id", run_dir.name)
    replayed = [o for o in outcomes if o.get("replay")]
    return {
        "title": f"ScenWeave run {run_id}", "run_id": run_id,
        "mode": run.get("mode", "?"), "input": run.get("input", "?"),
        "started_at": run.get("started_at", "?"), "written_at": summary.get("written_at", "?"),
        "finished": len(outcomes), "total": run.get("scenarios"),
        "counts": count_boxes(m["counts"], len(outcomes)),
        "per_class": _per_class_table(by_class(outcomes), m, outcomes),
        "taxonomy": Table(["error", "count"], [[k, v] for k, v in m["error_taxonomy"].items()]),
        "replay": _replay_overview(run_dir, replayed) if replayed else None,
        "figures": _run_figures(run_dir, outcomes) if outcomes else [],
        "variants": variant_table([o for o in outcomes if o.get("variants")]),
        "scenarios": _scenario_table(run_dir, outcomes),
        "issues": _issue_tables(summary.get("input_issues") or []),
    }


def _issue_tables(issues: list[dict]) -> list[tuple[str, Table]]:
    """The refused records and the input warnings, each with its heading, when there are any."""
    errors = [i for i in issues if i.get("severity", "error") == "error"]
    warnings = [i for i in issues if i.get("severity") == "warning"]
    return [(title, Table(["file", "row", "field", "message"],
                          [[i.get("file"), i.get("row"), i.get("field"), i.get("message")]
                           for i in listed], text_columns=4))
            for title, listed in (("Refused records (input errors)", errors),
                                  ("Input warnings (read, in a form not expected)", warnings))
            if listed]


def variant_table(varied: list[dict]) -> Table:
    """Each record's variants (``run --vary``): the distinct ones kept and what each changed,
    or why a variant was not kept."""
    rows = []
    for o in varied:
        kept = [v for v in o["variants"] if v.get("kept")]
        notes = "; ".join(f"{v['id']} {', '.join(v['changed'])}{_placed(v)}" if v.get("kept")
                          else f"{v['id']} ({v['aspect']}) not kept: "
                          f"{(v.get('errors') or ['?'])[0]}" for v in o["variants"])
        rows.append([o["scenario_id"], len(kept), len(o["variants"]), notes])
    return Table(["scenario", "kept", "asked", "variants"], rows, column_classes={3: "text"})


def _variant_table(varied: list[dict]) -> str:
    """The variants table as HTML."""
    return str(_macros().table(variant_table(varied)))


def _placed(variant: dict) -> str:
    """What a kept variant was asked to change: `` (road 35 lane -1)`` for the lane,
    `` (npc car → van)`` for a vehicle model; nothing for what the LLM chose itself."""
    asked, placed = variant.get("asked") or {}, variant.get("placed")
    if placed:
        return f" (road {placed['ego_road_id']} lane {placed['ego_lane_id']})"
    models = [f"{key.removesuffix('_vehicle_type')} {old} → {new}"
              for key, (old, new) in asked.items() if key.endswith("_vehicle_type")]
    return f" ({', '.join(models)})" if models else ""


def _per_class_table(grouped: dict[str, list[dict]], m: dict, outcomes: list[dict]) -> Table:
    """The metrics per class and in all; with a ``replay`` column (passed/played) when any
    scenario of the run was played in esmini."""
    rows = [metrics_row(code, metrics(g)) for code, g in grouped.items()] + [metrics_row("all", m)]
    if not any(o.get("replay") for o in outcomes):
        return Table(METRICS_HEADER, rows)
    groups = [*grouped.values(), outcomes]
    return Table([*METRICS_HEADER, "replay"],
                 [[*row, replay_rate(group)] for row, group in zip(rows, groups, strict=True)])


def replay_counts(outcomes: Iterable[dict]) -> tuple[int, int]:
    """(passed, played) of the outcomes whose scenario was played in esmini."""
    played = [o["replay"] for o in outcomes if o.get("replay")]
    return sum(bool(r.get("passed")) for r in played), len(played)


def replay_rate(outcomes: Iterable[dict]) -> str:
    """``passed/played (pct)``, ``–`` when none was played."""
    passed, played = replay_counts(outcomes)
    return f"{passed}/{played} ({pct(_rate(passed, played))})" if played else "–"


def _replay_overview(run_dir: Path, replayed: list[dict]) -> dict[str, Any]:
    """The replay sections: how many played and passed, the findings counted, the errors
    against the recorded series, and the replay figures."""
    from scenweave.replay_figures import is_current

    passed, played = replay_counts(replayed)
    codes = Counter(c for o in replayed for c in o["replay"].get("codes") or [])
    picks = replay_figure_picks(
        replayed, drawn=lambda o: is_current(run_dir / safe_name(o["scenario_id"]), o))
    return {
        "played": played, "passed": passed, "rate": pct(_rate(passed, played)),
        "engine": sum(not o["replay"].get("played", True) for o in replayed),
        "findings": Table(["replay finding", "scenarios"],
                          [[code, n] for code, n in sorted(codes.items())]),
        "series": _series_table(replayed),
        "failed": sum(not o["replay"].get("passed") for o in replayed),
        "failed_shown": sum(not o["replay"].get("passed") for o in picks),
        "passing_per_class": REPLAY_PASSING_PER_CLASS,
        "figures": [shown for shown in (_replay_figure(run_dir, o) for o in picks)
                    if shown["figure"] or shown["problem"]],
    }


def _series_table(replayed: list[dict]) -> Table:
    """Against the recorded series (mined records): per quantity, the scenarios compared and
    the largest max and RMS error over them (``series_errors``, docs/scenario-conventions.md)."""
    errors: dict[str, list[dict]] = {}
    for o in replayed:
        for name, error in (o["replay"].get("series_errors") or {}).items():
            errors.setdefault(name.split(" ", 1)[1], []).append(error)
    return Table(["quantity", "scenarios", "largest max error", "largest RMS error"],
                 [[k, len(v), f"{max(e['max'] for e in v):.2f}",
                   f"{max(e['rms'] for e in v):.2f}"] for k, v in sorted(errors.items())])


def replay_figure_picks(replayed: list[dict], passing_per_class: int = REPLAY_PASSING_PER_CLASS,
                        limit: int = REPLAY_FIGURES_MAX,
                        drawn: Callable[[dict], bool] | None = None) -> list[dict]:
    """The outcomes whose replay figure the report shows: every failed replay (taken class by
    class in turn when there are more than ``limit``), then up to ``passing_per_class``
    passing ones per class while there is room, those whose figure is ``drawn`` already (by
    the worker that made them) first."""
    failed = by_class(o for o in replayed if not o["replay"].get("passed"))
    passing = {code: sorted(group, key=lambda o: not drawn(o)) if drawn else group
               for code, group in by_class(o for o in replayed
                                           if o["replay"].get("passed")).items()}
    picks: list[dict] = []
    queues = [list(group) for group in failed.values()]
    while queues and len(picks) < limit:
        picks += [queue.pop(0) for queue in queues][:limit - len(picks)]
        queues = [queue for queue in queues if queue]
    for group in passing.values():
        picks += group[:max(0, min(passing_per_class, limit - len(picks)))]
    order = {id(o): i for i, o in enumerate(replayed)}
    return sorted(picks, key=lambda o: (o["replay"].get("passed", False), order[id(o)]))


def _replay_figure(run_dir: Path, outcome: dict) -> dict[str, Any]:
    """One picked replay: its figure (a missing or stale ``replay.svg`` is drawn first), or
    why there is none (``problem``); neither without a replay."""
    svg = _replay_svg(run_dir / safe_name(outcome["scenario_id"]), outcome)
    replay = outcome["replay"]
    verdict = ("replay passed" if replay.get("passed") else
               "replay failed: " + (", ".join(replay.get("codes") or []) or "?"))
    caption = f"{outcome['scenario_id']} ({outcome.get('maneuver_class', '?')}): {verdict}"
    return {"caption": caption,
            "figure": Figure(svg, caption, f"replay of {outcome['scenario_id']}",
                             SVG) if isinstance(svg, bytes) else None,
            "problem": svg if isinstance(svg, str) else None}


def _replay_svg(folder: Path, status: dict) -> bytes | str | None:
    """The folder's ``replay.svg`` (drawn when missing or not drawn from the present
    ``replay.json`` and verdict); the reason as text when it cannot be drawn; None without a
    replay."""
    from scenweave.replay_figures import draw_replay_figure, is_current

    source, picture = folder / REPLAY_JSON, folder / REPLAY_FIGURE
    if not source.exists():
        return None
    try:
        if not is_current(folder, status):
            draw_replay_figure(folder, status=status)
        return picture.read_bytes()
    except Exception as err:  # noqa: BLE001 - one broken picture must not cost the report
        return f"{type(err).__name__}: {err}"


def _run_figures(run_dir: Path, outcomes: list[dict]) -> list[Figure]:
    latencies = {name: [v for v in map(latency_s, group) if v is not None]
                 for name, group in _domains(outcomes).items()}
    cumulative = {f"projected, sequential, {name}": projected_curve(values)
                  for name, values in latencies.items() if values}
    cumulative["observed"] = observed_curve(run_dir, outcomes)
    return [
        Figure(plot_latency_per_class({"run": outcomes}),
               "Mean latency ± standard deviation per class (thesis Fig. 6.2).",
               "latency per class"),
        Figure(plot_latency_boxplot(outcomes),
               "Distribution of latencies per class (thesis Fig. 6.3).", "latency boxplot"),
        Figure(plot_cumulative(cumulative),
               "Cumulative scenarios: projected for one sequential pipeline over an hour "
               "(thesis Fig. 6.4) and as observed in this run.", "cumulative scenarios"),
    ]


def _domains(outcomes: list[dict]) -> dict[str, list[dict]]:
    groups: dict[str, list[dict]] = {"mix": outcomes}
    for o in outcomes:
        groups.setdefault(f"{o.get('domain', '?')} only", []).append(o)
    return groups if len(groups) > 2 else {"mix": outcomes}


def _scenario_table(run_dir: Path, outcomes: list[dict]) -> Table:
    """One row per scenario; the ``files`` column holds (href, text) links, the ``error``
    column the error text (run_report.html draws both)."""
    rows = [[o["scenario_id"], o.get("maneuver_class"), o.get("status"), o.get("attempts"),
             o.get("spawn_id"), _sec(latency_s(o)), scenario_links(o["scenario_id"], run_dir),
             o.get("error") or ""] for o in outcomes]
    return Table(["scenario", "class", "status", "attempts", "spawn", "latency s", "files",
                  "error"], rows, text_columns=3,
                 column_classes={2: "status", 6: "text", 7: "text"},
                 row_classes=[f"status-{o.get('status')}" for o in outcomes])


def write_run_report(run_dir: Path) -> Path:
    """Write ``report.html`` into the run folder (atomically) and return its path."""
    path = Path(run_dir) / REPORT_FILE
    write_text_atomic(path, render_run_report(Path(run_dir)))
    return path


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None

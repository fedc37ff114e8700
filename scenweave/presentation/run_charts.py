"""The charts of a run and of a benchmark (SVG, drawn with ``charts`` and ``plot``): latency
per class (bars ± std), the latency box plot (quartile box, median, 1.5 IQR whiskers,
fliers), the cumulative step curves and the latency-vs-success scatter.
"""


from __future__ import annotations

from dataclasses import dataclass
from typing import cast

from scenweave.presentation.charts import (
    SERIES_COLOURS,
    Chart,
    Panel,
    padded,
    render_svg,
)
from scenweave.presentation.metrics import by_class, latency_s, latency_stats, percentile
from scenweave.presentation.plot import Entry, Plot, category_label_depth

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

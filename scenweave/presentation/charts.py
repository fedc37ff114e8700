"""Charts drawn as SVG from a template: the primitives every picture of ScenWeave shares.

A chart is computed here in figure coordinates (pixels, y down) and drawn by
``templates/chart.svg`` (Jinja2, every value escaped: a record's text is shown, never run):

- a ``Scale`` maps data onto a panel's frame, ``nice_ticks`` puts its ticks at nice numbers;
- a ``Plot`` (``plot``) collects what a panel shows in data units and turns it into pixels;
- lines become SVG path data (``path_data``), thinned to what a pixel can show.

The replay figures (``replay_figures``) and the run and benchmark charts (``report``) are
drawn with these.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from scenweave.presentation.templating import render

TEMPLATE = "chart.svg"
#: font sizes (px) and the width of an average character, as a share of the font size
TITLE_PX, LABEL_PX, TICK_PX, LEGEND_PX, CAPTION_PX = 12.5, 10.0, 8.75, 8.1, 9.4
CHAR_EM = 0.56
#: line dashes (``stroke-dasharray``) of matplotlib's "--", "-." and ":"
DASHED, DASH_DOT, DOTTED = "5 3", "6 2 1.5 2", "1.5 2"
#: a line keeps one point per this many pixels along it (the rest is too fine to see)
THIN_PX = 1.5
#: the colours of one series after another (matplotlib's "tab10")
SERIES_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
                  "#7f7f7f", "#bcbd22", "#17becf")
GRID_COLOUR = "#b0b0b0"
MUTED = "#57606a"


# --- what the template draws -----------------------------------------------------------------

@dataclass(frozen=True)
class Stroke:
    """A line (SVG path data, unfilled)."""

    d: str
    colour: str
    width: float
    dash: str = ""
    opacity: float = 1.0
    cls: str = ""
    kind: str = "stroke"


@dataclass(frozen=True)
class Shape:
    """A filled outline (a mark: circle, diamond, square, star, X; a bar, a box, a span)."""

    d: str
    fill: str
    edge: str = "none"
    width: float = 0.0
    opacity: float = 1.0
    cls: str = ""
    kind: str = "shape"


@dataclass(frozen=True)
class Text:
    """Words at (x, y), turned by ``angle`` degrees (negative: counter-clockwise) about it."""

    x: float
    y: float
    text: str
    size: float
    colour: str = "black"
    anchor: str = "start"
    angle: float = 0.0
    mono: bool = False
    cls: str = ""


@dataclass
class Group:
    """Items that belong together, named: ``<g class="{kind}" data-{kind}="{name}">`` with the
    name as its tooltip (an actor's path, a class's box)."""

    kind: str
    name: str
    items: list[Stroke | Shape] = field(default_factory=list)


@dataclass
class Panel:
    """One plot: what is drawn inside its frame (clipped: groups first, then the rest), over it
    and its words."""

    name: str
    frame: tuple[float, float, float, float]
    grid: list[Stroke] = field(default_factory=list)
    groups: list[Group] = field(default_factory=list)
    clipped: list[Stroke | Shape] = field(default_factory=list)
    over: list[Stroke | Shape] = field(default_factory=list)
    texts: list[Text] = field(default_factory=list)

    def group(self, kind: str, name: str) -> Group:
        """The panel's group of that kind and name (made on first use)."""
        for found in self.groups:
            if (found.kind, found.name) == (kind, name):
                return found
        self.groups.append(Group(kind, name))
        return self.groups[-1]


@dataclass
class Chart:
    """The whole picture: its size, its panels and its words (title, caption, message)."""

    title: str
    width: int
    height: int
    panels: list[Panel] = field(default_factory=list)
    texts: list[Text] = field(default_factory=list)


def render_svg(chart: Chart, template: str = TEMPLATE, **context: Any) -> str:
    """The chart as an SVG document (``template`` extends ``chart.svg``, ``context`` is what
    it adds)."""
    return render(template, chart=chart, **context)


# --- scales and ticks ------------------------------------------------------------------------

@dataclass(frozen=True)
class Scale:
    """Data ``low``..``high`` onto pixels ``start``..``end`` (``end`` < ``start`` for y)."""

    low: float
    high: float
    start: float
    end: float

    def __call__(self, value: Any) -> Any:
        return self.start + (value - self.low) * ((self.end - self.start) / (self.high - self.low))

    def ticks(self) -> list[tuple[float, str]]:
        """(pixel, label) at nice numbers (1, 2, 2.5, 5 × 10^k apart), about one every 80 px
        across and every 45 px up (a y scale runs up: ``end`` < ``start``)."""
        every_px = 45 if self.end < self.start else 80
        count = min(8, max(3, round(abs(self.end - self.start) / every_px)))
        return [(self(v), label) for v, label in nice_ticks(self.low, self.high, count)]


def nice_ticks(low: float, high: float, count: int) -> list[tuple[float, str]]:
    """Values in ``low``..``high`` at the nice step nearest to giving ``count`` intervals,
    labelled with as many decimals as the step needs."""
    raw = (high - low) / max(count, 1)
    if not raw > 0 or not math.isfinite(raw):
        return []
    magnitude = 10.0 ** math.floor(math.log10(raw))
    step = min((m * magnitude for m in (1.0, 2.0, 2.5, 5.0, 10.0)),
               key=lambda candidate: abs(math.log(candidate / raw)))
    text = f"{step:.10g}"
    decimals = len(text.split(".")[1]) if "." in text and "e" not in text else 0
    first = math.ceil(low / step - 1e-9)
    values = [(first + i) * step for i in range(int((high - first * step) / step + 1e-9) + 1)]
    return [(v, f"{0.0 if abs(v) < step * 1e-6 else v:.{decimals}f}") for v in values]


def padded(values: Sequence[float], share: float = 0.05) -> tuple[float, float]:
    """The range of ``values`` widened by ``share`` of it each side (0..1 for none, ± 1 around
    a single value)."""
    if not values:
        return 0.0, 1.0
    low, high = min(values), max(values)
    if high - low < 1e-9:
        return low - 1.0, high + 1.0
    margin = (high - low) * share
    return low - margin, high + margin


def text_width(text: str, size: float) -> float:
    """About how many pixels ``text`` takes at font ``size``."""
    return len(text) * size * CHAR_EM


# --- path data -------------------------------------------------------------------------------

def path_data(xs: Any, ys: Any, thin_px: float = THIN_PX) -> str:
    """SVG path data through the points (pixels), a new piece after every missing (NaN)
    value; of the points within ``thin_px`` along the line only the first is kept."""
    xs, ys = thinned(np.asarray(xs, dtype=float), np.asarray(ys, dtype=float), thin_px)
    points = np.column_stack([xs, ys])
    present = np.isfinite(points).all(axis=1).astype(np.int8)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], present, [0]])))
    return "".join("M" + ("%.1f,%.1f " * (end - start) % tuple(points[start:end].ravel().tolist()))
                   [:-1] for start, end in zip(edges[::2].tolist(), edges[1::2].tolist(),
                                               strict=True))


def thinned(xs: np.ndarray, ys: np.ndarray, thin_px: float) -> tuple[np.ndarray, np.ndarray]:
    """The points with one kept per ``thin_px`` of line, and every piece's ends."""
    if len(xs) < 3:
        return xs, ys
    missing = ~(np.isfinite(xs) & np.isfinite(ys))
    steps = np.nan_to_num(np.hypot(np.diff(xs), np.diff(ys)), nan=0.0)
    bucket = np.floor(np.concatenate([[0.0], np.cumsum(steps)]) / thin_px)
    keep = np.concatenate([[True], bucket[1:] != bucket[:-1]]) | missing
    keep[1:] |= missing[:-1]
    keep[:-1] |= missing[1:]
    keep[-1] = True
    return xs[keep], ys[keep]


def steps_after(xs: Sequence[float], ys: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The corners of a step curve that holds each value until the next x (matplotlib's
    ``where="post"``)."""
    x, y = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
    if len(x) < 2:
        return x, y
    corners_x = np.empty(2 * len(x) - 1)
    corners_y = np.empty(2 * len(x) - 1)
    corners_x[0::2], corners_y[0::2] = x, y
    corners_x[1::2], corners_y[1::2] = x[1:], y[:-1]
    return corners_x, corners_y


def rect_path(x0: float, y0: float, x1: float, y1: float) -> str:
    """SVG path data of the rectangle between two corners (pixels)."""
    return f"M{x0:.1f},{y0:.1f}H{x1:.1f}V{y1:.1f}H{x0:.1f}Z"


def error_bar_path(x: float, low: float, high: float, cap: float) -> str:
    """SVG path data of a vertical bar from ``low`` to ``high`` at ``x`` with caps ``cap``
    pixels either side (pixels)."""
    return (f"M{x:.1f},{low:.1f}V{high:.1f}M{x - cap:.1f},{low:.1f}h{2 * cap}"
            f"M{x - cap:.1f},{high:.1f}h{2 * cap}")


def mark_path(shape: str, x: float, y: float, size: float) -> str:
    """SVG path data of a mark of ``size`` pixels across, centred on (x, y)."""
    r = size / 2
    if shape == "circle":
        return f"M{x - r:.1f},{y:.1f}a{r:.2f},{r:.2f} 0 1,0 {size:.2f},0" \
               f"a{r:.2f},{r:.2f} 0 1,0 {-size:.2f},0Z"
    if shape == "square":
        return f"M{x - r:.1f},{y - r:.1f}h{size:.1f}v{size:.1f}h{-size:.1f}Z"
    if shape == "diamond":
        return f"M{x:.1f},{y - r:.1f}L{x + r:.1f},{y:.1f}L{x:.1f},{y + r:.1f}L{x - r:.1f},{y:.1f}Z"
    if shape == "star":
        corners = [(r if i % 2 == 0 else r * 0.4, math.pi / 2 + i * math.pi / 5) for i in range(10)]
    else:  # "x": a plus of arms r long and r/3.5 thick, turned by 45°
        b = r / 3.5
        plus = [(b, r), (b, b), (r, b), (r, -b), (b, -b), (b, -r), (-b, -r), (-b, -b), (-r, -b),
                (-r, b), (-b, b), (-b, r)]
        corners = [(math.hypot(px, py), math.atan2(py, px) + math.pi / 4) for px, py in plus]
    return "M" + " L".join(f"{x + d * math.cos(a):.1f},{y - d * math.sin(a):.1f}"
                           for d, a in corners) + "Z"

"""A panel being drawn: a ``Plot`` collects what a panel shows in data units (lines, step
curves, rectangles, error bars, marks, words) and turns it into pixels once the scales are
known (``Plot.finish``): grid, ticks, tick labels (numbers, or categories turned 45°), axis
names and a legend in the corner that hides the fewest drawn points. The primitives it draws
with are ``charts``'.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenweave.presentation.charts import (
    CHAR_EM,
    GRID_COLOUR,
    LABEL_PX,
    LEGEND_PX,
    MUTED,
    TICK_PX,
    Panel,
    Scale,
    Shape,
    Stroke,
    Text,
    error_bar_path,
    mark_path,
    padded,
    path_data,
    rect_path,
    steps_after,
    text_width,
)


@dataclass(frozen=True)
class Entry:
    """One line of a legend: a line (dashed or not), a filled patch or a mark."""

    label: str
    colour: str = "black"
    dash: str = ""
    mark: str = ""
    patch: bool = False
    opacity: float = 0.3


#: (kind, name) of the group an item is drawn in; None: no group
Grouping = tuple[str, str] | None


class Plot:
    """A panel being drawn: lines, spans, rectangles and marks in data units, turned into
    pixels by ``finish`` once the scales are known (by default: the data's extent, 5 %
    margin)."""

    def __init__(self, name: str, frame: tuple[float, float, float, float]):
        self.name, self.frame = name, frame
        self._todo: list[Callable[[Scale, Scale, Panel], None]] = []
        self._xs: list[float] = []
        self._ys: list[float] = []
        self._points: list[np.ndarray] = []  # pixels the data covers, for the legend's place
        self.legend: list[Entry] = []
        self.legend_columns = 1

    def _extend(self, xs: Any, ys: Any) -> None:
        for target, values in ((self._xs, xs), (self._ys, ys)):
            found = np.asarray(values, dtype=float).ravel()
            found = found[np.isfinite(found)]
            if len(found):
                target += [float(found.min()), float(found.max())]

    @staticmethod
    def _put(panel: Panel, item: Stroke | Shape, group: Grouping) -> None:
        (panel.group(*group).items if group else panel.clipped).append(item)

    def line(self, xs: Any, ys: Any, colour: str, width: float, dash: str = "",
             opacity: float = 1.0, group: Grouping = None, cls: str = "") -> None:
        xs, ys = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
        self._extend(xs, ys)

        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            px, py = sx(xs), sy(ys)
            self._points.append(np.column_stack([px, py]))
            self._put(panel, Stroke(path_data(px, py), colour, width, dash, opacity, cls), group)
        self._todo.append(draw)

    def step(self, xs: Sequence[float], ys: Sequence[float], colour: str, width: float,
             group: Grouping = None, cls: str = "") -> None:
        """A step curve holding each value until the next x."""
        self.line(*steps_after(xs, ys), colour, width, group=group, cls=cls)

    def span(self, x0: float, x1: float, colour: str, opacity: float) -> None:
        """A shaded band across the whole height, from x0 to x1."""
        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            panel.clipped.append(Shape(rect_path(sx(x0), sy.end, sx(x1), sy.start), colour,
                                       opacity=opacity))
        self._todo.append(draw)

    def rect(self, x0: float, x1: float, y0: float, y1: float, fill: str, edge: str = "none",
             edge_width: float = 0.0, group: Grouping = None, cls: str = "") -> None:
        """A rectangle between (x0, y0) and (x1, y1): a bar, a box."""
        self._extend([x0, x1], [y0, y1])

        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            left, right, low, high = sx(x0), sx(x1), sy(y0), sy(y1)
            inside = np.linspace(0.0, 1.0, 5)
            self._points.append(np.array([(left + a * (right - left), low + b * (high - low))
                                          for a in inside for b in inside]))
            self._put(panel, Shape(rect_path(left, low, right, high), fill, edge, edge_width,
                                   cls=cls), group)
        self._todo.append(draw)

    def error_bar(self, x: float, low: float, high: float, colour: str, width: float = 1.0,
                  cap_px: float = 2.5, clip: bool = True, group: Grouping = None,
                  cls: str = "") -> None:
        """A vertical bar from ``low`` to ``high`` at ``x`` with caps."""
        self._extend([x], [low, high])

        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            stroke = Stroke(error_bar_path(float(sx(x)), sy(low), sy(high), cap_px), colour,
                            width, cls=cls)
            if clip:
                self._put(panel, stroke, group)
            else:
                panel.over.append(stroke)
        self._todo.append(draw)

    def segment(self, x0: float, y0: float, x1: float, y1: float, colour: str, width: float,
                group: Grouping = None, cls: str = "") -> None:
        """A straight line from (x0, y0) to (x1, y1), unthinned."""
        self._extend([x0, x1], [y0, y1])

        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            self._put(panel, Stroke(f"M{sx(x0):.1f},{sy(y0):.1f}L{sx(x1):.1f},{sy(y1):.1f}",
                                    colour, width, cls=cls), group)
        self._todo.append(draw)

    def hline(self, y: float, colour: str, width: float, dash: str = "") -> None:
        self._extend([], [y])
        self._todo.append(lambda sx, sy, panel: panel.clipped.append(Stroke(
            f"M{sx.start:.1f},{sy(y):.1f}H{sx.end:.1f}", colour, width, dash)))

    def vline(self, x: float, colour: str, width: float, dash: str = "") -> None:
        self._todo.append(lambda sx, sy, panel: panel.clipped.append(Stroke(
            f"M{sx(x):.1f},{sy.start:.1f}V{sy.end:.1f}", colour, width, dash)))

    def mark(self, x: float, y: float, shape: str, colour: str, size: float,
             fill: str | None = None, edge: str | None = None, edge_width: float = 1.2,
             tolerance: float = 0.0, clip: bool = True, cls: str = "",
             group: Grouping = None) -> None:
        """A mark (``fill`` None: the colour), with a bar of ± ``tolerance`` when given."""
        self._extend([x], [y - tolerance, y + tolerance])

        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            px, py = float(sx(x)), float(sy(y))
            self._points.append(np.array([[px, py]]))
            drawn: list[Stroke | Shape] = []
            if tolerance:
                drawn.append(Stroke(error_bar_path(px, sy(y - tolerance), sy(y + tolerance),
                                                   2.5), colour, 1.2))
            drawn.append(Shape(mark_path(shape, px, py, size), fill or colour,
                               edge or colour, edge_width, cls=cls))
            for item in drawn:
                if clip:
                    self._put(panel, item, group)
                else:
                    panel.over.append(item)
        self._todo.append(draw)

    def label(self, x: float, y: float, text: str, colour: str, cls: str = "") -> None:
        """A boxed label beside the point (x, y), toward the middle of the panel."""
        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            px, py = float(sx(x)), float(sy(y))
            left = px > (sx.start + sx.end) / 2
            width = text_width(text, TICK_PX) + 4
            at = px - 9 - width if left else px + 9
            panel.over.append(Shape(f"M{at:.1f},{py - 17:.1f}h{width:.1f}v12h{-width:.1f}Z",
                                    "white", opacity=0.8))
            panel.texts.append(Text(round(at + 2, 1), round(py - 8, 1), text, TICK_PX, colour,
                                    cls=cls))
        self._todo.append(draw)

    def annotate(self, x: float, y: float, text: str, dx: float = 6.0, dy: float = -4.0,
                 size: float = LEGEND_PX, cls: str = "") -> None:
        """Words beside the point (x, y), ``dx``, ``dy`` pixels off it: to its right, or to
        its left where they would leave the frame."""
        right_edge = self.frame[0] + self.frame[2]

        def draw(sx: Scale, sy: Scale, panel: Panel) -> None:
            px, py, width = float(sx(x)), float(sy(y)) + dy, text_width(text, size)
            left = px + dx + width > right_edge
            at = px - dx if left else px + dx
            self._points.append(np.array([[at - width if left else at, py],
                                          [at if left else at + width, py]]))
            panel.texts.append(Text(round(at, 1), round(py, 1), text, size,
                                    anchor="end" if left else "start", cls=cls))
        self._todo.append(draw)

    def note(self, text: str) -> None:
        """A word in the middle of the panel, instead of a plot."""
        x, y, width, height = self.frame
        self._todo.append(lambda sx, sy, panel: panel.texts.append(Text(
            x + width / 2, y + height / 2, text, LABEL_PX, MUTED, anchor="middle")))

    def auto_scales(self, x_range: tuple[float, float] | None = None,
                    y_range: tuple[float, float] | None = None) -> tuple[Scale, Scale]:
        """Scales around the data (``x_range``, ``y_range``: the limits as given), 5 %
        margin."""
        x, y, width, height = self.frame
        low_x, high_x = x_range or padded(self._xs)
        low_y, high_y = y_range or padded(self._ys)
        return Scale(low_x, high_x, x, x + width), Scale(low_y, high_y, y + height, y)

    @property
    def y_values(self) -> list[float]:
        """The lowest and highest y of each thing drawn so far (data units)."""
        return list(self._ys)

    def finish(self, scales: tuple[Scale, Scale], x_labels: bool = True, x_label: str = "",
               y_label: str = "", title: str = "", grid: str = "xy",
               categories: Sequence[tuple[float, str]] | None = None) -> Panel:
        """The panel in pixels: what was drawn, the axes (``grid``: along which of "x" and
        "y" grid lines run; ``categories``: (x, name) ticks instead of numbers, names turned
        45°) and the legend."""
        sx, sy = scales
        panel = Panel(self.name, self.frame)
        for draw in self._todo:
            draw(sx, sy, panel)
        draw_axes(panel, sx, sy, x_labels, x_label, y_label, title, grid, categories)
        if self.legend:
            place_legend(panel, self.legend, self.legend_columns, self._points)
        return panel


def category_label_depth(names: Sequence[str]) -> float:
    """Pixels below a frame that category names turned 45° take."""
    return 12 + max((text_width(n, TICK_PX) for n in names), default=0.0) * math.sqrt(0.5)


def draw_axes(panel: Panel, sx: Scale, sy: Scale, x_labels: bool = True, x_label: str = "",
              y_label: str = "", title: str = "", grid: str = "xy",
              categories: Sequence[tuple[float, str]] | None = None) -> None:
    """The frame's grid, ticks, tick labels and axis names."""
    x, y, width, height = panel.frame
    bottom, right = y + height, x + width
    ticks = []
    if categories is None:
        for px, label in sx.ticks():
            if "x" in grid:
                panel.grid.append(Stroke(f"M{px:.1f},{y:.1f}V{bottom:.1f}", GRID_COLOUR, 0.5))
            ticks.append(f"M{px:.1f},{bottom:.1f}v4")
            if x_labels:
                panel.texts.append(Text(round(px, 1), bottom + 14, label, TICK_PX,
                                        anchor="middle", cls="tick-x"))
    else:
        for value, name in categories:
            px = float(sx(value))
            ticks.append(f"M{px:.1f},{bottom:.1f}v4")
            if x_labels:
                panel.texts.append(Text(round(px + 3, 1), bottom + 10, name, TICK_PX,
                                        anchor="end", angle=-45.0, cls="tick-x"))
    widest = 0
    for py, label in sy.ticks():
        if "y" in grid:
            panel.grid.append(Stroke(f"M{x:.1f},{py:.1f}H{right:.1f}", GRID_COLOUR, 0.5,
                                     cls="grid-y"))
        ticks.append(f"M{x:.1f},{py:.1f}h-4")
        panel.texts.append(Text(x - 6, round(py + 3, 1), label, TICK_PX, anchor="end",
                                cls="tick-y"))
        widest = max(widest, len(label))
    panel.over.append(Stroke("".join(ticks), "black", 0.8))
    panel.over.append(Stroke(f"M{x},{y}H{right}V{bottom}H{x}Z", "black", 0.8))
    if x_label:
        depth = 28 if categories is None else category_label_depth([n for _, n in categories]) + 14
        panel.texts.append(Text(x + width / 2, bottom + depth, x_label, LABEL_PX,
                                anchor="middle"))
    if y_label:
        panel.texts.append(Text(round(x - 12 - widest * TICK_PX * CHAR_EM, 1), y + height / 2,
                                y_label, LABEL_PX, anchor="middle", angle=-90.0))
    if title:
        panel.texts.append(Text(x + width / 2, y - 6, title, LABEL_PX, anchor="middle"))


def place_legend(panel: Panel, entries: list[Entry], columns: int,
                 points: list[np.ndarray]) -> None:
    """The legend in the corner (or edge middle) of the frame that hides the fewest drawn
    points, as matplotlib's ``loc="best"`` does."""
    rows = math.ceil(len(entries) / columns)
    column_width = 26 + max(text_width(e.label, LEGEND_PX) for e in entries)
    width, height = columns * column_width + 4, rows * 11.5 + 6
    x, y, frame_width, frame_height = panel.frame
    spots = [(x + frame_width - width - 4, y + 4), (x + 4, y + 4),
             (x + 4, y + frame_height - height - 4),
             (x + frame_width - width - 4, y + frame_height - height - 4),
             (x + (frame_width - width) / 2, y + 4),
             (x + (frame_width - width) / 2, y + frame_height - height - 4)]
    every = np.vstack(points) if points else np.empty((0, 2))

    def hidden(spot: tuple[float, float]) -> int:
        inside = ((every[:, 0] >= spot[0]) & (every[:, 0] <= spot[0] + width)
                  & (every[:, 1] >= spot[1]) & (every[:, 1] <= spot[1] + height))
        return int(inside.sum())

    left, top = min(spots, key=hidden)
    panel.over.append(Shape(f"M{left:.1f},{top:.1f}h{width:.1f}v{height:.1f}h{-width:.1f}Z",
                            "white", "#cccccc", 0.8, opacity=0.85, cls="legend"))
    for i, entry in enumerate(entries):
        ex = left + 4 + (i % columns) * column_width
        ey = top + 3 + (i // columns) * 11.5 + 5.75
        if entry.patch:
            panel.over.append(Shape(f"M{ex:.1f},{ey - 3.5:.1f}h18v7h-18Z", entry.colour,
                                    opacity=entry.opacity))
        elif entry.mark:
            panel.over.append(Shape(mark_path(entry.mark, ex + 9, ey, 6), "white",
                                    entry.colour, 1.2))
        else:
            panel.over.append(Stroke(f"M{ex:.1f},{ey:.1f}h18", entry.colour, 1.6, entry.dash))
        panel.texts.append(Text(round(ex + 22, 1), round(ey + 3, 1), entry.label, LEGEND_PX,
                                cls="legend"))

"""A picture of the map with its spawn points, for the person who reviews the database.

Left: the whole map; right: the densest area (the town) enlarged, with spawn ids. Roads are
drawn from the OpenDRIVE lanes; spawn points are arrows in their driving direction, coloured
by context, filled by priority (suitability), ringed when a person has reviewed them; traffic
lights are marked. Coordinates are CARLA's (y axis pointing down, as seen from above).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from scenweave.files import write_bytes_atomic  # noqa: E402
from scenweave.roads.lanes import lane_center_offset, section_samples  # noqa: E402
from scenweave.roads.road_network import RoadNetwork  # noqa: E402
from scenweave.roads.signals import is_traffic_light, signal_position  # noqa: E402

CONTEXT_COLOURS = {"highway": "#1f77b4", "urban": "#d62728", "rural": "#2ca02c",
                   "divided road": "#9467bd"}
ARROW_M = 6.0


def plot_spawn_points(network: RoadNetwork, database: dict[str, Any], out_path: Path,
                      dpi: int = 110) -> None:
    """Write a PNG of the map and the database's spawn points to ``out_path`` (atomically)."""
    entries = database["spawn_points"]
    figure, (overview, zoom) = plt.subplots(1, 2, figsize=(22, 11),
                                            gridspec_kw={"width_ratios": [1, 1]})
    for axes in (overview, zoom):
        _draw_roads(axes, network)
        _draw_lights(axes, network)
        _draw_spawns(axes, entries)
        axes.set_aspect("equal")
        axes.set_xlabel("CARLA x (m)")
        axes.set_ylabel("CARLA y (m)")
        axes.grid(True, linewidth=0.3, alpha=0.5)
    overview.invert_yaxis()
    bounds = _densest_area(entries)
    if bounds is not None:
        (x0, x1), (y0, y1) = bounds
        zoom.set_xlim(x0, x1)
        zoom.set_ylim(y1, y0)
        overview.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False,
                                     linestyle="--", linewidth=1.0, color="black"))
        _label_ids(zoom, entries, bounds)
    else:
        zoom.invert_yaxis()
    counts = {c: sum(e["context"] == c for e in entries) for c in CONTEXT_COLOURS}
    reviewed = sum(e["annotations"]["manually_reviewed"] for e in entries)
    overview.set_title(f"{database['metadata']['map']}: {len(entries)} spawn points "
                       f"({', '.join(f'{n} {c}' for c, n in counts.items() if n)}), "
                       f"{reviewed} reviewed")
    zoom.set_title("enlarged: spawn ids next to their arrows")
    overview.legend(handles=_legend(), loc="lower left", fontsize=9)
    figure.tight_layout()
    write_bytes_atomic(out_path, _png_bytes(figure, dpi))
    plt.close(figure)


def _png_bytes(figure: Figure, dpi: int) -> bytes:
    from io import BytesIO

    buffer = BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
    return buffer.getvalue()


def _draw_roads(axes: Axes, network: RoadNetwork) -> None:
    for key in network.drivable_lanes():
        road = network.road(key.road_id)
        section = road.sections[key.section]
        s = section_samples(section)
        t, _ = lane_center_offset(road, section, key.lane_id, s)
        pose = road.plan_view.pose(s)
        x = pose.x - t * np.sin(pose.hdg)
        y = pose.y + t * np.cos(pose.hdg)
        colour, width = ("#bbbbbb", 0.6) if road.in_junction else ("#777777", 0.9)
        axes.plot(x, -y, color=colour, linewidth=width, zorder=1)


def _draw_lights(axes: Axes, network: RoadNetwork) -> None:
    for road in network.map.roads.values():
        for signal in road.signals:
            if is_traffic_light(signal):
                pose = signal_position(network, signal)
                axes.plot(pose.x, -pose.y, marker="s", markersize=5, color="#ff9900",
                          markeredgecolor="black", markeredgewidth=0.5, zorder=4)


def _draw_spawns(axes: Axes, entries: list[dict[str, Any]]) -> None:
    for entry in entries:
        transform = entry["transform"]
        yaw = np.radians(transform["yaw"])
        colour = CONTEXT_COLOURS.get(entry["context"], "black")
        alpha = 0.35 + 0.65 * entry["annotations"]["priority"] / 3.0
        reviewed = entry["annotations"]["manually_reviewed"]
        axes.annotate("", xy=(transform["x"] + ARROW_M * np.cos(yaw),
                              transform["y"] + ARROW_M * np.sin(yaw)),
                      xytext=(transform["x"], transform["y"]),
                      arrowprops={"arrowstyle": "-|>", "color": colour, "alpha": alpha,
                                  "linewidth": 1.2}, zorder=3)
        axes.plot(transform["x"], transform["y"], marker="o", markersize=3.5, color=colour,
                  alpha=alpha, markeredgecolor="black" if reviewed else colour,
                  markeredgewidth=1.2 if reviewed else 0.0, zorder=3)


Bounds = tuple[tuple[float, float], tuple[float, float]]


def _densest_area(entries: list[dict[str, Any]], size: float = 340.0) -> Bounds | None:
    """The ``size`` x ``size`` window holding the most spawn points (None if no points)."""
    if not entries:
        return None
    points = np.array([[e["transform"]["x"], e["transform"]["y"]] for e in entries])
    best: Bounds | None = None
    best_count = -1
    for x0 in np.arange(points[:, 0].min(), points[:, 0].max() + 1, size / 8):
        for y0 in np.arange(points[:, 1].min(), points[:, 1].max() + 1, size / 8):
            inside = ((points[:, 0] >= x0) & (points[:, 0] <= x0 + size)
                      & (points[:, 1] >= y0) & (points[:, 1] <= y0 + size))
            if int(inside.sum()) > best_count:
                best, best_count = ((x0 - 10, x0 + size + 10), (y0 - 10, y0 + size + 10)), int(
                    inside.sum())
    return best


def _label_ids(axes: Axes, entries: list[dict[str, Any]], bounds: Bounds) -> None:
    (x0, x1), (y0, y1) = bounds
    for entry in entries:
        x, y = entry["transform"]["x"], entry["transform"]["y"]
        if x0 <= x <= x1 and y0 <= y <= y1:
            axes.text(x + 1.0, y - 1.0, str(entry["spawn_id"]), fontsize=5, zorder=5,
                      color=CONTEXT_COLOURS.get(entry["context"], "black"))


def _legend() -> list[Line2D]:
    handles = [Line2D([], [], marker="o", linestyle="", color=colour, label=f"{context} spawn")
               for context, colour in CONTEXT_COLOURS.items() if context in ("highway", "urban")]
    handles += [
        Line2D([], [], marker="o", linestyle="", color="grey", alpha=0.45,
               label="priority 1 (pale) .. 3 (solid)"),
        Line2D([], [], marker="o", linestyle="", color="white", markeredgecolor="black",
               markeredgewidth=1.2, label="manually reviewed"),
        Line2D([], [], marker="s", linestyle="", color="#ff9900", markeredgecolor="black",
               label="traffic light"),
        Line2D([], [], color="#777777", label="lane (junction lanes lighter)"),
    ]
    return handles

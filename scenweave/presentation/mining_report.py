"""``mining_report.html``: what ``scenweave mine`` found, drawn from ``mining_report.json``.

Events per class and file, a histogram of every parameter of every class (what a lab wants to
see before it spends simulation time on the records), and what was skipped and why. The page
is ``templates/mining_report.html``; this module computes what it shows.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from scenweave.files.atomic import write_text_atomic
from scenweave.presentation.report import Table
from scenweave.presentation.templating import render

HISTOGRAM_BINS = 12
SHOWN_SKIPS = 200
#: the size of one histogram in pixels
HISTOGRAM_WIDTH, HISTOGRAM_HEIGHT = 200, 90


def write_mining_report(report_json: Path) -> Path:
    """Render the report next to its JSON; return the HTML's path."""
    report = json.loads(Path(report_json).read_text(encoding="utf-8"))
    out = Path(report_json).with_suffix(".html")
    write_text_atomic(out, render_mining_report(report))
    return out


def render_mining_report(report: dict) -> str:
    return render("mining_report.html", **mining_report_context(report))


def mining_report_context(report: dict) -> dict[str, Any]:
    """What ``templates/mining_report.html`` shows of a ``mining_report.json``."""
    written = report["records_by_class"]
    files = report["files"]
    classes = sorted({c for f in files.values() for c in f["events_by_class"]} | set(written))
    rate = (report["vehicle_hours"] * 3600 / report["seconds"]) if report["seconds"] else None
    return {
        "title": "ScenWeave mining report",
        "records_written": report["records_written"], "files": len(files),
        "vehicle_hours": f"{report['vehicle_hours']:.2f}", "seconds": f"{report['seconds']:.2f}",
        "real_time": f"{rate:,.0f}" if rate else None,
        "skipped_count": len(report["skipped"]), "repeats": len(report.get("duplicates", [])),
        "per_file": Table(["file", "reader", "tracks", "vehicle-hours", *classes],
                          [[name, f["reader"], f["tracks"], f"{f['vehicle_hours']:.3f}",
                            *(f["events_by_class"].get(c, 0) for c in classes)]
                           for name, f in sorted(files.items())], text_columns=2),
        "written": Table(["", *classes],
                         [["records written", *(written.get(c, 0) for c in classes)]]),
        "histograms": [_class_histograms(code, values)
                       for code, values in sorted(report["values"].items())],
        "skipped": Table(["scenario", "field", "why"],
                         [[s["scenario_id"], s["field"] or "", s["reason"]]
                          for s in report["skipped"][:SHOWN_SKIPS]], text_columns=3),
        "warnings": report["warnings"],
    }


def _class_histograms(code: str, values: dict[str, list[float]]) -> dict[str, Any]:
    """A class's histograms, one per parameter with numbers, counted with numpy and drawn as
    SVG by the template: the report takes milliseconds where a plotting library took longer
    than the mining itself."""
    charts = (_histogram(name, values[name]) for name in sorted(values))
    return {"code": code, "count": len(next(iter(values.values()), [])),
            "charts": [chart for chart in charts if chart is not None]}


def _histogram(name: str, values: list[float]) -> dict[str, Any] | None:
    """The bars of one parameter's histogram (SVG coordinates), None when it has no finite
    number."""
    numbers = np.asarray([v for v in values if isinstance(v, int | float)], dtype=float)
    numbers = numbers[np.isfinite(numbers)]
    if not len(numbers):
        return None
    counts, edges = np.histogram(numbers, bins=HISTOGRAM_BINS)
    bar = HISTOGRAM_WIDTH / len(counts)
    top = max(int(counts.max()), 1)
    tall = HISTOGRAM_HEIGHT - 30  # the tallest bar; room for the name above, the range below
    bars = [{"x": f"{k * bar:.1f}", "y": f"{HISTOGRAM_HEIGHT - 14 - n / top * tall:.1f}",
             "width": f"{bar - 1:.1f}", "height": f"{n / top * tall:.1f}",
             "title": f"{edges[k]:.3g} to {edges[k + 1]:.3g}: {n}"}
            for k, n in enumerate(counts.tolist())]
    return {"name": name, "width": HISTOGRAM_WIDTH, "height": HISTOGRAM_HEIGHT, "bars": bars,
            "low": f"{edges[0]:.3g}", "high": f"{edges[-1]:.3g}"}

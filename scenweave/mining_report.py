"""``mining_report.html``: what ``scenweave mine`` found, drawn from ``mining_report.json``.

Events per class and file, a histogram of every parameter of every class (what a lab wants to
see before it spends simulation time on the records), and what was skipped and why.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from scenweave.files.atomic import write_text_atomic
from scenweave.report import page, table

HISTOGRAM_BINS = 12
SHOWN_SKIPS = 200


def write_mining_report(report_json: Path) -> Path:
    """Render the report next to its JSON; return the HTML's path."""
    report = json.loads(Path(report_json).read_text(encoding="utf-8"))
    out = Path(report_json).with_suffix(".html")
    write_text_atomic(out, render_mining_report(report))
    return out


def render_mining_report(report: dict) -> str:
    written = report["records_by_class"]
    files = report["files"]
    classes = sorted({c for f in files.values() for c in f["events_by_class"]} | set(written))
    repeats = len(report.get("duplicates", []))
    rate = (report["vehicle_hours"] * 3600 / report["seconds"]) if report["seconds"] else None
    summary = (f"<p>{report['records_written']} records written from {len(files)} files "
               f"({report['vehicle_hours']:.2f} vehicle-hours of driving, mined in "
               f"{report['seconds']:.2f} s"
               + (f", {rate:,.0f}x real time" if rate else "") + "); "
               f"{len(report['skipped'])} events skipped, {repeats} dropped as repeats of an "
               f"earlier file's.</p>")
    per_file = table(["file", "reader", "tracks", "vehicle-hours", *classes],
                     [[name, f["reader"], f["tracks"], f"{f['vehicle_hours']:.3f}",
                       *(f["events_by_class"].get(c, 0) for c in classes)]
                      for name, f in sorted(files.items())], text_columns=2)
    written_row = table(["", *classes], [["records written", *(written.get(c, 0)
                                                               for c in classes)]])
    histograms = "".join(_histograms(code, values)
                         for code, values in sorted(report["values"].items()))
    skipped = table(["scenario", "field", "why"],
                    [[s["scenario_id"], s["field"] or "", s["reason"]]
                     for s in report["skipped"][:SHOWN_SKIPS]], text_columns=3)
    warnings = "".join(f"<li>{html.escape(w)}</li>" for w in report["warnings"])
    body = (f"<h1>Mining report</h1>{summary}<h2>Events per file</h2>{per_file}{written_row}"
            f"<h2>Parameters of the written records</h2>{histograms or '<p>none</p>'}"
            f"<h2>Skipped</h2>{skipped}"
            + (f"<h2>Warnings</h2><ul>{warnings}</ul>" if warnings else ""))
    return page("ScenWeave mining report", body)


def _histograms(code: str, values: dict[str, list[float]]) -> str:
    """One small SVG bar chart per parameter, counted with numpy: drawn as text, so the report
    takes milliseconds where a plotting library took longer than the mining itself."""
    count = len(next(iter(values.values()), []))
    charts = "".join(_svg_histogram(name, values[name]) for name in sorted(values))
    return (f"<h3>{html.escape(code)}: {count} records</h3>"
            f'<div style="display:flex;flex-wrap:wrap;gap:8px">{charts}</div>')


def _svg_histogram(name: str, values: list[float], width: int = 200,
                   height: int = 90) -> str:
    numbers = np.asarray([v for v in values if isinstance(v, int | float)], dtype=float)
    numbers = numbers[np.isfinite(numbers)]
    if not len(numbers):
        return ""
    counts, edges = np.histogram(numbers, bins=HISTOGRAM_BINS)
    bar = width / len(counts)
    top = max(int(counts.max()), 1)
    bars = "".join(
        f'<rect x="{k * bar:.1f}" y="{height - 14 - n / top * (height - 30):.1f}" '
        f'width="{bar - 1:.1f}" height="{n / top * (height - 30):.1f}" fill="#4c72b0">'
        f"<title>{edges[k]:.3g} to {edges[k + 1]:.3g}: {n}</title></rect>"
        for k, n in enumerate(counts.tolist()))
    return (f'<svg width="{width}" height="{height}" role="img" '
            f'aria-label="histogram of {html.escape(name)}">'
            f'<text x="0" y="11" font-size="10">{html.escape(name)}</text>{bars}'
            f'<text x="0" y="{height - 2}" font-size="9">{edges[0]:.3g}</text>'
            f'<text x="{width}" y="{height - 2}" font-size="9" text-anchor="end">'
            f"{edges[-1]:.3g}</text></svg>")

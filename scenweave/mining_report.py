"""``mining_report.html``: what ``scenweave mine`` found, drawn from ``mining_report.json``.

Events per class and file, a histogram of every parameter of every class (what a lab wants to
see before it spends simulation time on the records), and what was skipped and why.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from scenweave.files.atomic import write_text_atomic
from scenweave.report import figure, figure_png, page, pyplot, table

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
    rate = (report["vehicle_hours"] * 3600 / report["seconds"]) if report["seconds"] else None
    summary = (f"<p>{report['records_written']} records written from {len(files)} files "
               f"({report['vehicle_hours']:.2f} vehicle-hours of driving, mined in "
               f"{report['seconds']:.2f} s"
               + (f", {rate:,.0f}x real time" if rate else "") + "); "
               f"{len(report['skipped'])} events skipped.</p>")
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
    plt = pyplot()
    names = sorted(values)
    columns = 4
    rows = (len(names) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.4 * rows), squeeze=False)
    for ax, name in zip(axes.flat, names, strict=False):
        ax.hist(values[name], bins=HISTOGRAM_BINS, color="#4c72b0")
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=8)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    fig.suptitle(f"{code}: {len(next(iter(values.values()), []))} records", fontsize=11)
    fig.tight_layout()
    return figure(figure_png(fig), f"{code}: the distribution of each parameter",
                  f"histograms of {code}'s parameters")

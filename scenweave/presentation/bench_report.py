"""What a benchmark did, for a reader: the thesis figures (SVG files beside ``bench.json``) and
``bench.html``, rendered from ``templates/bench.html`` (Jinja2, every value escaped: a model's
or a benchmark's name is shown, never run)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenweave.files.atomic import write_bytes_atomic, write_json_atomic, write_text_atomic
from scenweave.presentation.metrics import latency_s, projected_curve
from scenweave.presentation.report import METRICS_HEADER, Figure, Table, metrics_row, pct
from scenweave.presentation.run_charts import (
    plot_cumulative,
    plot_latency_boxplot,
    plot_latency_per_class,
    plot_latency_vs_success,
)
from scenweave.presentation.templating import render

BENCH_FILE = "bench.json"
BENCH_HTML = "bench.html"
BOXPLOT_PREFIX = "fig6_3_latency_boxplot_"


def model_dir_name(model: str) -> str:
    """A file or folder name for a model tag such as ``qwen2.5-coder:7b``."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", model)


@dataclass
class BenchFigure:
    """One SVG chart of the benchmark: its file name in the benchmark folder and its caption."""

    file: str
    image: bytes
    caption: str
    alt: str


def figures(summary: dict, outcomes_by_model: dict[str, list[dict]]) -> dict[str, BenchFigure]:
    """Figs. 6.1, 6.2, 6.3 (one boxplot per model) and 6.4 of the benchmark, in page order;
    keys as in ``bench.json``'s ``figures``."""
    overall = {model: entry["overall"] for model, entry in summary["models"].items()}
    curves = {model: projected_curve([v for v in map(latency_s, outcomes) if v is not None])
              for model, outcomes in outcomes_by_model.items()}
    made = {
        "latency_vs_success": BenchFigure(
            "fig6_1_latency_vs_success.svg", plot_latency_vs_success(overall),
            "Latency vs success rate per model (Fig. 6.1).", "latency vs success"),
        "latency_per_class": BenchFigure(
            "fig6_2_latency_per_class.svg", plot_latency_per_class(outcomes_by_model),
            "Mean latency ± std per class and model (Fig. 6.2).", "latency per class"),
    }
    for model, outcomes in outcomes_by_model.items():
        made[f"latency_boxplot/{model}"] = BenchFigure(
            f"{BOXPLOT_PREFIX}{model_dir_name(model)}.svg", plot_latency_boxplot(outcomes),
            f"Distribution of latencies per class, {model} (Fig. 6.3).",
            f"latency boxplot {model}")
    made["cumulative"] = BenchFigure(
        "fig6_4_scenarios_per_hour.svg", plot_cumulative(curves),
        "Projected scenarios over one hour of sequential running per model (Fig. 6.4).",
        "scenarios per hour")
    return made


def write_bench(root: Path, summary: dict, outcomes_by_model: dict[str, list[dict]]) -> Path:
    """Write ``bench.json``, the figures (SVG) and ``bench.html`` into ``root``."""
    made = figures(summary, outcomes_by_model)
    for made_figure in made.values():
        write_bytes_atomic(root / made_figure.file, made_figure.image)
    summary = {**summary, "figures": {key: f.file for key, f in made.items()}}
    write_json_atomic(root / BENCH_FILE, summary)
    write_text_atomic(root / BENCH_HTML, render_bench(root.name, summary, made))
    return root / BENCH_FILE


def render_bench(name: str, summary: dict, made: dict[str, BenchFigure]) -> str:
    """The benchmark as a static HTML page: the thesis tables and figures."""
    return render("bench.html", **bench_context(name, summary, made))


def bench_context(name: str, summary: dict, made: dict[str, BenchFigure]) -> dict[str, Any]:
    """What ``templates/bench.html`` shows: the tables per model and per class, the error
    taxonomy (None without errors) and the figures."""
    models = list(summary["models"])

    def rates(entry: dict, code: str) -> str:
        group = entry["by_class"].get(code, {})
        return f"{pct(group.get('success_rate'))} / {pct(group.get('first_attempt_rate'))}"

    errors = summary["error_table"]
    return {
        "title": f"ScenWeave benchmark {name}", "name": name,
        "per_model": Table(METRICS_HEADER, [metrics_row(model, entry["overall"])
                                            for model, entry in summary["models"].items()]),
        "latency": Table(["class", *models], [[code, *(_cell(row[m], ".1f") for m in models)]
                                              for code, row in summary["latency_table"].items()]),
        "rates": Table(["class", *models],
                       [[code, *(rates(entry, code) for entry in summary["models"].values())]
                        for code in summary["latency_table"]]),
        "errors": Table(["error", *models], [[error, *(row[m] for m in models)]
                                             for error, row in errors.items()]) if errors else None,
        "figures": [Figure(f.image, f"{f.caption} File {f.file}.", f.alt) for f in made.values()],
    }


def _cell(value: Any, fmt: str) -> str:
    return "–" if value is None else format(value, fmt)

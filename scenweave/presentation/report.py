"""What a run did, for a reader: ``report.html``, one static, self-contained page.

The numbers are ``metrics``' (thesis §6.1), the charts ``run_charts``', the replay figures
``replay_figures``'; figures are inline ``data:`` SVG images, links are relative to the run
folder. The page is rendered from ``templates/run_report.html`` (Jinja2, every value
escaped); this module only computes what the page shows.
"""

from __future__ import annotations

import base64
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenweave.files.atomic import write_text_atomic
from scenweave.presentation.metrics import (
    by_class,
    latency_s,
    metrics,
    observed_curve,
    projected_curve,
    rate,
)
from scenweave.presentation.run_charts import (
    SVG,
    plot_cumulative,
    plot_latency_boxplot,
    plot_latency_per_class,
)
from scenweave.presentation.templating import render
from scenweave.run_folder import safe_name
from scenweave.schemas.scenario_folder import (
    FIGURE_NAME,
    REPLAY_NAME,
    REPORT_FILE,
    RUN_FILE,
    SCENARIO_FILES,
    STATUSES,
    SUMMARY_FILE,
    read_json_object,
)

#: replay figures embedded in a run's report: every failed replay, up to this many passing
#: ones per class, at most this many in all
REPLAY_PASSING_PER_CLASS = 1
REPLAY_FIGURES_MAX = 40


# --- the data the templates show -----------------------------------------------------------

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
    summary = read_json_object(run_dir / SUMMARY_FILE)
    run = read_json_object(run_dir / RUN_FILE)
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
        "not_played": _not_played(summary),
        "figures": _run_figures(run_dir, outcomes) if outcomes else [],
        "variants": variant_table([o for o in outcomes if o.get("variants")]),
        "scenarios": _scenario_table(run_dir, outcomes),
        "issues": _issue_tables(summary.get("input_issues") or []),
    }


def _not_played(summary: dict) -> dict | None:
    """How many delivered scenarios were never played in esmini and why (``summary.json``'s
    ``replay.not_played``, ``scenweave.unplayed``), for the banner; None when all were."""
    replay = summary.get("replay") or {}
    if not replay.get("not_played"):
        return None
    because = str(replay.get("not_played_because") or "unknown")
    return {"count": replay["not_played"], "because": because.split(" (", 1)[0],
            "detail": because}


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
    return f"{passed}/{played} ({pct(rate(passed, played))})" if played else "–"


def _replay_overview(run_dir: Path, replayed: list[dict]) -> dict[str, Any]:
    """The replay sections: how many played and passed, the findings counted, the errors
    against the recorded series, and the replay figures."""
    passed, played = replay_counts(replayed)
    codes = Counter(c for o in replayed for c in o["replay"].get("codes") or [])
    drawn = _FigureCurrent(run_dir)
    picks = replay_figure_picks(replayed, drawn=drawn)
    return {
        "played": played, "passed": passed, "rate": pct(rate(passed, played)),
        "engine": sum(not o["replay"].get("played", True) for o in replayed),
        "findings": Table(["replay finding", "scenarios"],
                          [[code, n] for code, n in sorted(codes.items())]),
        "series": _series_table(replayed),
        "failed": sum(not o["replay"].get("passed") for o in replayed),
        "failed_shown": sum(not o["replay"].get("passed") for o in picks),
        "passing_per_class": REPLAY_PASSING_PER_CLASS,
        "figures": [shown for shown in (_replay_figure(run_dir, o, drawn) for o in picks)
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
    passing = by_class(o for o in replayed if o["replay"].get("passed"))
    picks: list[dict] = []
    queues = [list(group) for group in failed.values()]
    while queues and len(picks) < limit:
        picks += [queue.pop(0) for queue in queues][:limit - len(picks)]
        queues = [queue for queue in queues if queue]
    for group in passing.values():
        picks += _drawn_first(group, max(0, min(passing_per_class, limit - len(picks))), drawn)
    order = {id(o): i for i, o in enumerate(replayed)}
    return sorted(picks, key=lambda o: (o["replay"].get("passed", False), order[id(o)]))


def _drawn_first(group: list[dict], count: int,
                 drawn: Callable[[dict], bool] | None) -> list[dict]:
    """The first ``count`` of ``group`` with those ``drawn`` already first (each in its
    order), asking ``drawn`` (which reads a scenario's files) only until ``count`` are found:
    the report's end costs the same for 20 scenarios of a class as for 2,000."""
    if count == 0 or drawn is None:
        return group[:count]
    found: list[dict] = []
    others: list[dict] = []
    for outcome in group:
        (found if drawn(outcome) else others).append(outcome)
        if len(found) == count:
            return found
    return (found + others)[:count]


class _FigureCurrent:
    """Whether a scenario's ``replay.svg`` is current (``replay_figures.is_current``), asked
    once per scenario: it reads and digests the scenario's ``replay.json``, and the picks and
    the figures of the report both ask."""

    def __init__(self, run_dir: Path) -> None:
        self.run_dir = run_dir
        self.known: dict[str, bool] = {}

    def __call__(self, outcome: dict) -> bool:
        from scenweave.presentation.replay_figures import is_current

        scenario_id = outcome["scenario_id"]
        if scenario_id not in self.known:
            self.known[scenario_id] = is_current(self.run_dir / safe_name(scenario_id), outcome)
        return self.known[scenario_id]


def _replay_figure(run_dir: Path, outcome: dict, drawn: _FigureCurrent) -> dict[str, Any]:
    """One picked replay: its figure (a missing or stale ``replay.svg`` is drawn first), or
    why there is none (``problem``); neither without a replay."""
    svg = _replay_svg(run_dir / safe_name(outcome["scenario_id"]), outcome, drawn)
    replay = outcome["replay"]
    verdict = ("replay passed" if replay.get("passed") else
               "replay failed: " + (", ".join(replay.get("codes") or []) or "?"))
    caption = f"{outcome['scenario_id']} ({outcome.get('maneuver_class', '?')}): {verdict}"
    return {"caption": caption,
            "figure": Figure(svg, caption, f"replay of {outcome['scenario_id']}",
                             SVG) if isinstance(svg, bytes) else None,
            "problem": svg if isinstance(svg, str) else None}


def _replay_svg(folder: Path, status: dict, drawn: _FigureCurrent) -> bytes | str | None:
    """The folder's ``replay.svg`` (drawn when missing or not drawn from the present
    ``replay.json`` and verdict); the reason as text when it cannot be drawn; None without a
    replay."""
    from scenweave.presentation.replay_figures import draw_replay_figure

    source, picture = folder / REPLAY_NAME, folder / FIGURE_NAME
    if not source.exists():
        return None
    try:
        if not drawn(status):
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

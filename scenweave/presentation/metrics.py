"""Metrics over outcomes (thesis §6.1): success rate (SR, the LLM's own success: ``ok`` or
``repaired``), first-attempt rate, latency per scenario and the error taxonomy; a fallback
still delivers a scenario, so ``delivered_rate`` counts it too. They work on outcome dicts
(``status.json`` of each scenario, the ``scenarios`` of ``summary.json``), so they run the
same on a ``--no-llm`` run, an agent run and a benchmark.
"""


from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

from scenweave.run_folder import safe_name
from scenweave.schemas.scenario_folder import STATUS_NAME, STATUSES

HOUR_S = 3600.0


def rate(part: int, whole: int) -> float | None:
    """``part`` of ``whole`` rounded to 4 places, None of nothing."""
    return round(part / whole, 4) if whole else None


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
        "success_rate": rate(counts["ok"] + counts["repaired"], n),
        "delivered_rate": rate(n - counts["failed"], n),
        "first_attempt_rate": rate(sum(bool(o.get("first_attempt_success"))
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
        path = Path(run_dir) / safe_name(o["scenario_id"]) / STATUS_NAME
        if path.exists():
            points.append((path.stat().st_mtime, latency_s(o) or 0.0))
    if not points:
        return []
    start = min(end - took for end, took in points)
    return [(t, n) for n, t in enumerate(sorted(end - start for end, _ in points), start=1)]

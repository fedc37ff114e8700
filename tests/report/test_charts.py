"""The run and benchmark charts (``run_charts.plot_*``, drawn with ``charts``): each is a
well-formed SVG, a record's text in it is shown and never run, and what it draws lands where
the data says (read back through the chart's own y axis: its grid lines and tick labels)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from lxml import etree

from scenweave.presentation.charts import Scale, nice_ticks, path_data, steps_after
from scenweave.presentation.metrics import metrics
from scenweave.presentation.run_charts import (
    box_stats,
    plot_cumulative,
    plot_latency_boxplot,
    plot_latency_per_class,
    plot_latency_vs_success,
)

SVG = "{http://www.w3.org/2000/svg}"
SCRIPT_CLASS = "U<script>alert(1)</script>&co"
#: latencies per class, chosen so that the quartiles fall between data points (a quartile
#: taken as the nearest value, or a median of the middle pair missed, lands elsewhere) and
#: each class has one value beyond a whisker (LCF below its box, the others above)
LATENCIES = {"BRAKE": [1.0, 2.0, 3.0, 4.0, 10.0], SCRIPT_CLASS: [0.5, 1.5, 2.0, 2.25, 6.0],
             "LCF": [3.0, 3.1, 3.2, 3.3, 3.4, 0.5]}


def outcomes(latencies: dict[str, list[float]] = LATENCIES) -> list[dict]:
    return [{"scenario_id": f"{code}_{i}", "maneuver_class": code, "status": "ok",
             "timings_s": {"total": value}}
            for code, values in latencies.items() for i, value in enumerate(values)]


def charts() -> dict[str, bytes]:
    made = outcomes()
    return {
        "per class": plot_latency_per_class({"run": made, "<b>model</b> & co": made[:6]}),
        "boxplot": plot_latency_boxplot(made),
        "cumulative": plot_cumulative({"observed": [(30.0, 1), (90.0, 2), (150.0, 3)],
                                       "<i>projected</i>": [(60.0, 1), (120.0, 2)]}),
        "vs success": plot_latency_vs_success({"<m>&model": metrics(made),
                                               "other": metrics(made[:3])}),
    }


def _parse(svg: bytes) -> etree._Element:
    root = etree.fromstring(svg)  # raises unless well-formed XML
    assert root.tag == f"{SVG}svg"
    width, height = int(root.get("width")), int(root.get("height"))
    assert width >= 640 and height > 300
    assert root.get("viewBox") == f"0 0 {width} {height}"
    return root


def _groups(root: etree._Element, kind: str) -> dict[str, etree._Element]:
    return {g.get(f"data-{kind}"): g for g in root.iter(f"{SVG}g") if g.get("class") == kind}


def _of_class(element: etree._Element, cls: str) -> list[etree._Element]:
    return [e for e in element.iter() if e.get("class") == cls]


def _y_axis(root: etree._Element) -> Scale:
    """The chart's y scale as a reader finds it: the value of each tick label against the
    height of its grid line."""
    heights = [float(re.match(r"M[\d.]+,([\d.]+)H", path.get("d")).group(1))
               for path in _of_class(root, "grid-y")]
    values = [float(text.text) for text in _of_class(root, "tick-y")]
    assert len(heights) == len(values) >= 3
    (low, bottom), (high, top) = (values[0], heights[0]), (values[-1], heights[-1])
    return Scale(low, high, bottom, top)


def _ys(d: str) -> list[float]:
    """The heights of the points a path moves or draws a line to."""
    return [float(y) for y in re.findall(r"-?[\d.]+,(-?[\d.]+)", d)]


def _vertical_span(path: etree._Element) -> list[float]:
    """Where a rectangle or an error bar starts and where its first vertical line ends
    (pixels, top first)."""
    d = path.get("d")
    return sorted([_ys(d)[0], float(re.search(r"V([\d.]+)", d).group(1))])


@pytest.mark.parametrize("name", ["per class", "boxplot", "cumulative", "vs success"])
def test_each_chart_is_a_well_formed_svg(name):
    root = _parse(charts()[name])
    assert root.find(f"{SVG}title").text
    assert root.findall(f".//{SVG}path")


def test_charts_of_nothing_are_still_well_formed():
    for svg in (plot_latency_per_class({"run": []}), plot_latency_boxplot([]),
                plot_cumulative({"observed": []}), plot_latency_vs_success({})):
        _parse(svg)


def test_a_name_with_markup_is_shown_as_text_never_run():
    for name, svg in charts().items():
        text = svg.decode()
        assert "<script" not in text and "<b>" not in text and "<i>" not in text, name
        assert "<m>" not in text and "&co" not in text.replace("&amp;co", ""), name
    root = _parse(charts()["boxplot"])
    assert SCRIPT_CLASS in ["".join(t.itertext()) for t in root.iter(f"{SVG}text")]
    assert SCRIPT_CLASS in _groups(root, "box")
    assert not root.xpath("//*[local-name()='script']")
    labels = ["".join(t.itertext()) for t in _parse(charts()["vs success"]).iter(f"{SVG}text")]
    assert "<m>&model" in labels
    legend = ["".join(t.itertext()) for t in _of_class(_parse(charts()["cumulative"]), "legend")]
    assert "<i>projected</i>: 2 in 2.0 min" in legend


def test_box_stats_agree_with_numpy():
    for values in LATENCIES.values():
        box = box_stats(values)
        assert (box.q1, box.median, box.q3) == pytest.approx(
            np.percentile(values, [25, 50, 75]))
        reach = 1.5 * (box.q3 - box.q1)
        inside = [v for v in values if box.q1 - reach <= v <= box.q3 + reach]
        assert (box.low, box.high) == (min(inside), max(inside))
        assert box.fliers == sorted(set(values) - set(inside))


def test_the_boxes_show_the_quartiles_median_and_whiskers_where_the_data_says():
    root = _parse(charts()["boxplot"])
    y = _y_axis(root)
    boxes = _groups(root, "box")
    assert list(boxes) == sorted(LATENCIES)  # one per class, classes sorted
    for code, values in LATENCIES.items():
        q1, median, q3 = np.percentile(values, [25, 50, 75])
        reach = 1.5 * (q3 - q1)
        inside = [v for v in values if q1 - reach <= v <= q3 + reach]
        [box] = _of_class(boxes[code], "quartiles")
        assert _vertical_span(box) == pytest.approx(sorted([y(q1), y(q3)]), abs=0.11), code
        [line] = _of_class(boxes[code], "median")
        assert _ys(line.get("d")) == pytest.approx([y(median)] * 2, abs=0.11), code
        caps = sorted(_ys(cap.get("d"))[0] for cap in _of_class(boxes[code], "cap"))
        assert caps == pytest.approx(sorted([y(min(inside)), y(max(inside))]), abs=0.11), code
        fliers = _of_class(boxes[code], "flier")
        assert len(fliers) == len(values) - len(inside) == 1, code


def test_the_bars_show_the_mean_and_the_standard_deviation():
    root = _parse(plot_latency_per_class({"run": outcomes()}))
    y = _y_axis(root)
    bars = _groups(root, "bar")
    assert len(bars) == len(LATENCIES)
    for code, values in LATENCIES.items():
        [group] = [g for name, g in bars.items() if name.startswith(f"run {code}: ")]
        [bar] = _of_class(group, "mean")
        assert _vertical_span(bar) == pytest.approx(
            sorted([y(np.mean(values)), y(0.0)]), abs=0.11), code
        [error] = _of_class(group, "error-bar")
        spread = np.std(values)
        assert _vertical_span(error) == pytest.approx(
            sorted([y(np.mean(values) - spread), y(np.mean(values) + spread)]), abs=0.11), code


def test_the_step_curve_holds_each_count_until_the_next():
    xs, ys = steps_after([0.0, 1.0, 3.0], [0, 1, 2])
    assert xs.tolist() == [0.0, 1.0, 1.0, 3.0, 3.0]
    assert ys.tolist() == [0, 0, 1, 1, 2]
    root = _parse(plot_cumulative({"observed": [(60.0, 1), (180.0, 2)]}))
    [curve] = _of_class(root, "curve")
    y = _y_axis(root)
    assert _ys(curve.get("d"))[-1] == pytest.approx(y(2), abs=0.11)


def test_ticks_are_nice_and_lines_break_at_missing_values():
    assert [label for _, label in nice_ticks(0.0, 1.0, 4)] == ["0.00", "0.25", "0.50", "0.75",
                                                               "1.00"]
    assert [label for _, label in nice_ticks(-0.1, 1.0, 5)] == ["0.0", "0.2", "0.4", "0.6",
                                                                "0.8", "1.0"]
    assert (path_data([0, 10, np.nan, 20, 30], [0, 0, 0, 5, 5])
            == "M0.0,0.0 10.0,0.0M20.0,5.0 30.0,5.0")

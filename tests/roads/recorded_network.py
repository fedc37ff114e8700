"""A small recorded lane network written by hand, shared by the recorded-road converter's
tests (as LaneStrips here, as CommonRoad XML in ``tests/mining/road_fixture.py``).

Traffic drives +x (its left is +y) unless said otherwise:

- x 0-50: a straight three-lane road (lanelets 1, 2, 3 left to right) and, beside lane 1, a
  lane the other way (20, driving -x);
- x 50-100: the three lanes go on (4, 5, 6); 6 flares from 3.5 m to 6.5 m (its right border
  moves out);
- x 100-150: 5 goes on straight (7); 8 leaves the flared lane 6 and narrows diagonally into
  the middle lane, so 9 (x 150-200) has two predecessors (a merge);
- x 200: a junction governed by light 500 (stop line at x = 200 on 9): 10 straight on
  (x 200-230, then 12 to x 280), 11 a left turn of radius 15 m (then 13, driving +y).
"""

from __future__ import annotations

import math

import numpy as np

from scenweave.roads.recorded_road import LaneStrip, RecordedLight

Points = list[tuple[float, float]]
LANE = 3.5
HALF = LANE / 2


def straight(x0: float, x1: float, y_left: float, y_right: float, n: int = 3
             ) -> tuple[Points, Points]:
    xs = [x0 + (x1 - x0) * k / (n - 1) for k in range(n)]
    return [(x, y_left) for x in xs], [(x, y_right) for x in xs]


def arc(cx: float, cy: float, radius: float, start_deg: float, end_deg: float, n: int = 10
        ) -> Points:
    return [(cx + radius * math.cos(math.radians(a)), cy + radius * math.sin(math.radians(a)))
            for a in (start_deg + (end_deg - start_deg) * k / (n - 1) for k in range(n))]


def lanelets() -> dict[int, dict[str, object]]:
    """Each lanelet's borders and links (what the XML is written from, and what the tests
    check against)."""
    flare_right = [(50.0 + 10 * k, -HALF - LANE - 3.0 * k / 5) for k in range(6)]
    merge_left = [(100.0 + 10 * k, -HALF + LANE * k / 5) for k in range(6)]
    merge_right = [(100.0 + 10 * k, -HALF - LANE - 3.0 + (LANE + 3.0) * k / 5) for k in range(6)]
    turn_centre = (200.0, 15.0)
    return {
        1: {"bounds": straight(0, 50, HALF + LANE, HALF), "succ": [4], "right": 2,
            "left": 20, "left_dir": "opposite"},
        2: {"bounds": straight(0, 50, HALF, -HALF), "succ": [5], "left": 1, "right": 3},
        3: {"bounds": straight(0, 50, -HALF, -HALF - LANE), "succ": [6], "left": 2},
        20: {"bounds": ([(50.0, HALF + LANE), (25.0, HALF + LANE), (0.0, HALF + LANE)],
                        [(50.0, HALF + 2 * LANE), (25.0, HALF + 2 * LANE),
                         (0.0, HALF + 2 * LANE)]),
             "left": 1, "left_dir": "opposite"},
        4: {"bounds": straight(50, 100, HALF + LANE, HALF), "pred": [1], "right": 5},
        5: {"bounds": straight(50, 100, HALF, -HALF), "pred": [2], "succ": [7], "left": 4,
            "right": 6},
        6: {"bounds": ([(x, -HALF) for x, _ in flare_right], flare_right), "pred": [3],
            "succ": [8], "left": 5},
        7: {"bounds": straight(100, 150, HALF, -HALF), "pred": [5], "succ": [9]},
        8: {"bounds": (merge_left, merge_right), "pred": [6], "succ": [9]},
        9: {"bounds": straight(150, 200, HALF, -HALF), "pred": [7, 8], "succ": [10, 11],
            "light": 500},
        10: {"bounds": straight(200, 230, HALF, -HALF), "pred": [9], "succ": [12]},
        11: {"bounds": (arc(*turn_centre, 15.0 - HALF, -90, 0), arc(*turn_centre, 15.0 + HALF,
                                                                   -90, 0)),
             "pred": [9], "succ": [13]},
        12: {"bounds": straight(230, 280, HALF, -HALF), "pred": [10]},
        13: {"bounds": ([(215.0 - HALF, 15.0), (215.0 - HALF, 40.0), (215.0 - HALF, 65.0)],
                        [(215.0 + HALF, 15.0), (215.0 + HALF, 40.0), (215.0 + HALF, 65.0)]),
             "pred": [11]},
    }


def strips(network: dict[int, dict[str, object]] | None = None) -> list[LaneStrip]:
    """The network as the converter's strips."""
    strips = []
    for lanelet_id, spec in (network or lanelets()).items():
        left, right = spec["bounds"]  # type: ignore[misc]
        strips.append(LaneStrip(
            id=str(lanelet_id), left=np.array(left, float), right=np.array(right, float),
            predecessors=tuple(str(i) for i in spec.get("pred", [])),  # type: ignore[attr-defined]
            successors=tuple(str(i) for i in spec.get("succ", [])),  # type: ignore[attr-defined]
            left_neighbour=str(spec["left"]) if "left" in spec else None,
            left_same_direction=spec.get("left_dir", "same") == "same",
            right_neighbour=str(spec["right"]) if "right" in spec else None,
            right_same_direction=spec.get("right_dir", "same") == "same"))
    return strips


def lights() -> list[RecordedLight]:
    """Light 500 on lanelet 9, its stop line across x = 200."""
    return [RecordedLight("500", ("9",), stop_lines=(("9", 200.0, HALF, 200.0, -HALF),))]

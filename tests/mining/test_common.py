"""The readers' shared helpers: headings from motion per segment, id order, header names."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenweave.mining.readers._common import header_key, id_order, segment_headings


def test_segment_headings_hold_through_stops_and_stay_within_a_segment():
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.0, 0.1, 0.2, 0.0, 0.1])
    # segment 1 drives +y then stops; segment 2 stands, then drives -x; segment 3 never moves
    x = np.array([0.0, 0.0, 0.0, 0.0, 5.0, 5.0, 4.0, 9.0, 9.0])
    y = np.array([0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 3.0, 3.0])
    heading = segment_headings(x, y, t, np.array([0, 4, 7]))
    assert heading[:4] == pytest.approx([math.pi / 2] * 4)
    assert heading[4:7] == pytest.approx([math.pi] * 3)  # its first moving heading before
    assert np.isnan(heading[7:]).all()


def test_id_order_is_natural():
    assert sorted(["10-2", "9", "10", "10-1", "b", "a"], key=id_order) == [
        "9", "10", "10-1", "10-2", "a", "b"]


def test_header_key_ignores_case_spacing_and_underscores():
    assert header_key(" Vehicle_ID ") == header_key("vehicle id") == "vehicleid"

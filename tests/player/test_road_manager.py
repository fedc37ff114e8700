"""esmini's RoadManager in a child process (player.road_manager): points located on a real
map, and a map esmini aborts on (a signal past its road's end) comes back as not loaded while
the caller goes on."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from scenweave.player.road_manager import PointGroup, probe_map
from scenweave.roads.recorded_road import convert
from tests.roads.recorded_network import HALF, LANE, lights, strips

pytestmark = pytest.mark.usefixtures("needs_esmini")


@pytest.fixture(scope="module")
def road_text() -> str:
    return convert(strips(), lights()).xodr.decode()


def test_points_are_located_on_their_road_and_lane(road_text: str, tmp_path: Path) -> None:
    path = tmp_path / "road.xodr"
    path.write_text(road_text, encoding="utf-8")
    # the middle lane (lanelet 2, road 1 lane -2) at x = 20, then the right lane at x = 30
    probe = probe_map(path, [PointGroup(1, -2, [(20.0, 0.0, 0.0)]),
                             PointGroup(1, -3, [(30.0, -HALF - LANE / 2, 0.0)])])
    assert probe.loaded, probe.problem
    (middle,), (right,) = probe.groups
    assert (middle.road_id, middle.lane_id) == (1, -2)
    assert abs(middle.lane_offset) < 0.01
    assert (right.road_id, right.lane_id, right.own_road_lane_id) == (1, -3, -3)
    assert right.own_road_s == pytest.approx(30.0, abs=0.01)
    # the centre line of road 1 lane -3 runs along y = -3.5 from x = 0 to x = 50
    xs, ys = zip(*probe.centres[1], strict=True)
    assert min(xs) == pytest.approx(0.0, abs=0.01) and max(xs) == pytest.approx(50.0, abs=0.01)
    assert max(abs(y + LANE) for y in ys) < 0.01


def test_a_map_esmini_aborts_on_is_reported_not_fatal(road_text: str, tmp_path: Path) -> None:
    path = tmp_path / "signal_past_end.xodr"
    path.write_text(re.sub(r'(<signal s=")[^"]*"', r'\g<1>9999"', road_text), encoding="utf-8")
    probe = probe_map(path, [PointGroup(1, -1, [(10.0, 3.5, 0.0)])])
    assert not probe.loaded
    assert "No lane section found" in probe.problem
    assert "\n" not in probe.problem


def test_a_file_that_is_no_map_is_not_loaded(tmp_path: Path) -> None:
    path = tmp_path / "broken.xodr"
    path.write_text("<OpenDRIVE><road", encoding="utf-8")
    probe = probe_map(path, [])
    assert not probe.loaded
    assert probe.problem

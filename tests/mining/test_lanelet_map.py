"""A recording's road (mining.readers.lanelet_map, mining.recorded_road): CommonRoad
lanelets and highD's lane markings read into strips, converted once per file content and
cached, refused by file and lanelet; on the shared NGSIM files (skipped where ../shared is
absent) the map check's targets; CARLA's parser where the ``carla`` package is installed."""

from __future__ import annotations

import importlib.util
import shutil
import stat
from pathlib import Path

import pytest

from scenweave.judge.map_check import carla_map_check, check_map
from scenweave.mining.readers import highd
from scenweave.mining.readers.lanelet_map import read_lanelet_map, read_road_network
from scenweave.mining.recorded_road import XODR_NAME, road_for
from scenweave.player import PlayerUnavailable, find_esmini
from scenweave.player.road_manager import PointGroup, probe_map
from scenweave.roads.errors import RecordedRoadError
from tests.mining.road_fixture import write_road_fixture

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "ngsim"
SHARED_FILES = sorted(SHARED.rglob("*.xml")) if SHARED.is_dir() else []
HAS_CARLA = importlib.util.find_spec("carla") is not None


@pytest.fixture
def fixture_file(tmp_path: Path) -> Path:
    return write_road_fixture(tmp_path / "ZAM_Road-1_1_T-1.xml")


def _esmini_or_skip() -> None:
    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(str(err))


def test_lanelets_lights_and_cycles_are_read(fixture_file: Path) -> None:
    road = read_lanelet_map(fixture_file)
    by_id = {s.id: s for s in road.strips}
    assert len(by_id) == 14
    assert by_id["9"].predecessors == ("7", "8")
    assert by_id["9"].successors == ("10", "11")
    assert (by_id["1"].right_neighbour, by_id["1"].right_same_direction) == ("2", True)
    assert (by_id["1"].left_neighbour, by_id["1"].left_same_direction) == ("20", False)
    assert by_id["6"].right[-1].tolist() == pytest.approx([100.0, -8.25])
    (light,) = road.lights
    assert light.strips == ("9",)
    assert light.stop_lines[0][0] == "9"
    # green 2 s, yellow 0.5 s, red from 2.5 s to the car's last step (2.9 s)
    assert [(p.start_s, p.end_s, p.state) for p in road.phases["500"]] == [
        (0.0, 2.0, "green"), (2.0, 2.5, "yellow"), (2.5, 2.9, "red")]


def test_converted_once_then_read_from_the_cache(fixture_file: Path, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    first = road_for(fixture_file, cache)
    assert not first.cached
    assert first.xodr.name == XODR_NAME and first.xodr.is_file()
    assert stat.S_IMODE(first.xodr.stat().st_mode) == 0o644
    written = first.xodr.stat().st_mtime_ns
    again = road_for(fixture_file, cache)
    assert again.cached
    assert (again.xodr, again.lanes, again.lights) == (first.xodr, first.lanes, first.lights)
    assert again.xodr.stat().st_mtime_ns == written
    (light,) = again.lights
    assert light.signal_ids and light.phases and light.lanelets == ("9",)
    assert again.lanes["9"] == first.lanes["9"]
    # the same content under another name is the same entry; other content another one
    twin = shutil.copy(fixture_file, tmp_path / "twin.xml")
    assert road_for(Path(twin), cache).xodr == first.xodr
    assert road_for(Path(twin), cache).source == str(twin)
    other = write_road_fixture(tmp_path / "other.xml", broken=None)
    other.write_text(other.read_text().replace("<x>280.0</x>", "<x>281.0</x>"))
    assert road_for(other, cache).xodr != first.xodr


def test_a_network_that_cannot_be_converted_names_file_and_lanelet(tmp_path: Path) -> None:
    broken = write_road_fixture(tmp_path / "broken.xml", broken=7)
    with pytest.raises(RecordedRoadError) as caught:
        road_for(broken, tmp_path / "cache")
    message = str(caught.value)
    assert message.startswith(f"{broken}: lanelet 7: ")
    assert "\n" not in message
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.xodr"))


def test_a_file_that_is_no_lane_network_is_refused_by_name(tmp_path: Path) -> None:
    junk = tmp_path / "junk.xml"
    junk.write_text("<commonRoad><lanelet id='1'>", encoding="utf-8")
    with pytest.raises(RecordedRoadError, match=f"^{junk}: not a readable lane network"):
        road_for(junk, tmp_path / "cache")
    with pytest.raises(RecordedRoadError, match="cannot be read"):
        road_for(tmp_path / "missing.xml", tmp_path / "cache")


def test_fixture_map_check_with_esmini(fixture_file: Path, tmp_path: Path) -> None:
    _esmini_or_skip()
    road = road_for(fixture_file, tmp_path / "cache")
    check = check_map(road.xodr, read_lanelet_map(fixture_file).strips, road.lanes)
    assert check.loaded and check.own_lane == 1.0 and check.error_max < 0.05


@pytest.mark.skipif(not SHARED_FILES, reason="the shared NGSIM data is not here")
@pytest.mark.parametrize("place", ["us101", "lankershim", "peachtree"])
def test_shared_maps_meet_the_map_targets(place: str, tmp_path: Path) -> None:
    """One file per location (the benchmark covers all): centre lines on their own road and
    lane and within 0.5 m for >= 99.5 % (US-101) / 98 % (urban) of samples, esmini loads."""
    _esmini_or_skip()
    file = next(f for f in SHARED_FILES if f.parent.name == place)
    road = road_for(file, tmp_path)
    check = check_map(road.xodr, read_lanelet_map(file).strips, road.lanes)
    target = 0.995 if place == "us101" else 0.98
    assert check.loaded, check.problem
    assert check.own_lane >= target and check.within_close >= target, check.line()


@pytest.mark.skipif(not SHARED_FILES, reason="the shared NGSIM data is not here")
def test_every_shared_file_converts(tmp_path: Path) -> None:
    for file in SHARED_FILES:
        road = road_for(file, tmp_path)
        assert road.lanes and road.xodr.stat().st_size > 0


@pytest.mark.skipif(not HAS_CARLA, reason="the carla package is not installed")
def test_carla_parses_the_maps_without_nan(fixture_file: Path, tmp_path: Path) -> None:
    files = [fixture_file, *SHARED_FILES]
    for file in files:
        road = road_for(file, tmp_path)
        carla = carla_map_check(road.xodr.read_text(encoding="utf-8"),
                                read_lanelet_map(file).strips, road.lanes)
        assert carla is not None
        assert carla.waypoints > 0 and carla.nan_waypoints == 0, file.name
        assert carla.own_lane > 0.95, (file.name, carla.line())


HIGHD = Path(__file__).resolve().parent / "data" / "highd" / "01_tracks.csv"


def test_highd_lanes_are_straight_strips_between_the_markings(tmp_path: Path) -> None:
    """Upper markings 1, 4.5, 8 (laneIds 2, 3, towards -x), lower 12, 15.5, 19 (5, 6,
    towards +x); one road per carriageway, and each vehicle's positions land on the lane its
    track names."""
    road = road_for(HIGHD, tmp_path)
    assert road.lanes == {"2": (1, -1), "3": (1, -2), "6": (2, -1), "5": (2, -2)}
    network = read_road_network(HIGHD)
    by_id = {s.id: s for s in network.strips}
    assert by_id["3"].left[:, 1].tolist() == [4.5, 4.5]
    assert by_id["3"].right[:, 1].tolist() == [8.0, 8.0]
    assert by_id["3"].left[0, 0] > by_id["3"].left[1, 0]  # towards -x
    assert by_id["5"].left[:, 1].tolist() == [15.5, 15.5]
    assert road_for(HIGHD, tmp_path).cached
    _esmini_or_skip()
    check = check_map(road.xodr, network.strips, road.lanes)
    assert check.own_lane == 1.0 and check.error_max < 0.01
    groups, expected = [], []
    for track in highd.read(HIGHD).tracks:
        for x, y, heading, lane in zip(track.x, track.y, track.heading, track.lane,
                                       strict=True):
            groups.append(PointGroup(*road.lanes[lane], [(x, y, heading)]))
            expected.append(road.lanes[lane])
    probe = probe_map(road.xodr, groups)
    found = [(g[0].road_id, g[0].lane_id) for g in probe.groups]
    assert found == expected

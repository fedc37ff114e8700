"""``scenweave export`` of a mined event's in-situ scenario: for plain esmini (the scenario with
its recorded road beside it, played by esmini's own command-line player from anywhere) and for
CARLA (the road for the OpenDRIVE standalone mode, the replay script and its data). Where the
``carla`` client package is installed, CARLA's own OpenDRIVE parser (``carla.Map``, no server)
reads every exported map without a NaN waypoint and puts the recorded positions, converted as
the script converts them, on driving lanes: on the fixture always, on the shared NGSIM files
where they are present. What needs a CARLA server (the world built from the road, spawning,
the ticks) is not tested here."""

from __future__ import annotations

import importlib.util
import math
import shutil
import subprocess
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from click.testing import CliRunner
from lxml import etree

from scenweave.cli import cli
from scenweave.exports.in_situ import replay_script
from scenweave.judge.carla_lint import carla_lint
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.player import find_esmini
from tests.viewer.in_situ_run import SCENARIO, VEHICLES, recording

pytestmark = pytest.mark.slow
HAS_CARLA = importlib.util.find_spec("carla") is not None
needs_carla = pytest.mark.skipif(not HAS_CARLA, reason="CARLA NOT TESTED: the carla client "
                                 "package is not installed (pip install carla)")


@pytest.fixture(scope="module")
def carla_export(in_situ_scene: Path, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("carla")
    result = CliRunner().invoke(cli, ["export", str(in_situ_scene.parent), "--for", "carla",
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "1/1 scenarios for CARLA (1 in situ)" in result.output
    return out / SCENARIO / "in_situ"


@pytest.fixture(scope="module")
def script(carla_export: Path) -> ModuleType:
    """The generated replay script, imported as a module (it imports carla only to run)."""
    spec = importlib.util.spec_from_file_location("replay_in_carla",
                                                  carla_export / "replay_in_carla.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_esmini_export_plays_in_plain_esmini_from_anywhere(in_situ_scene, tmp_path):
    out = tmp_path / "esmini"
    result = CliRunner().invoke(cli, ["export", str(in_situ_scene.parent), "--for", "esmini",
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "1/1 scenarios play in plain esmini (1 in situ)" in result.output
    folder = out / SCENARIO / "in_situ"
    assert (folder / "road.xodr").read_bytes() == (in_situ_scene / "in_situ" / "road.xodr"
                                                   ).read_bytes()
    assert (folder / "replay.dat").stat().st_size > 1000
    assert "--traj_filter 0" in (out / "README.md").read_text()
    moved = tmp_path / "elsewhere" / "copy"
    shutil.move(folder, moved)
    played = subprocess.run([str(find_esmini().home / "bin" / "esmini"), "--headless", "--osc",
                             str(moved / "scenario.xosc"), "--disable_log"], cwd=tmp_path,
                            capture_output=True, text=True, timeout=120, check=False)
    assert played.returncode == 0, played.stdout[-2000:]
    assert "completeState" in played.stdout and "Failed to" not in played.stdout


def test_the_carla_export_holds_the_road_the_script_and_its_data(carla_export, in_situ_scene):
    source = in_situ_scene / "in_situ"
    for name in ("scenario.xosc", "road.xodr"):
        assert (carla_export / name).read_bytes() == (source / name).read_bytes()
    text = (carla_export / "replay_in_carla.py").read_text()
    compile(text, "replay_in_carla.py", "exec")
    assert "generate_opendrive_world" in text and "synchronous_mode = True" in text
    assert "STEP_S = 0.1\n" in text
    assert (carla_export / "replay_in_carla.py").stat().st_mode & 0o111
    lint = (carla_export / "carla_lint.txt").read_text()
    assert "warning CARLA_PARTIAL" in lint and "error" not in lint
    assert f"{SCENARIO}: ego track 1, 4 recorded vehicles" in text
    readme = (carla_export.parent.parent / "README.md").read_text()
    assert f"`{SCENARIO}/in_situ/`" in readme and "--ego external" in readme


def test_the_script_puts_every_vehicle_on_its_recorded_pose_in_carlas_frame(script):
    scene = script.json.loads(script.TRAJECTORIES.read_text())
    by_name = {v["name"]: v for v in scene["vehicles"]}
    assert scene["step_s"] == 0.1 and len(by_name) == len(VEHICLES)
    for track in recording(Path("unused")).tracks:
        vehicle = by_name["hero" if track.id == "1" else f"v{track.id}"]
        assert vehicle["t"][0] == pytest.approx(track.t[0]) and \
            vehicle["t"][-1] == pytest.approx(track.t[-1])
        # the scenario keeps the vertices a line between their neighbours would miss by 5 mm
        # or 5 mrad: between them the script interpolates as esmini does
        for t, x, y, h in zip(track.t, track.x, track.y, track.heading, strict=True):
            cx, cy, yaw = script.to_carla(*script.pose_at(vehicle, float(t)))
            assert math.hypot(cx - x, cy + y) < 0.01, (vehicle["name"], t)
            assert yaw == pytest.approx(-math.degrees(h), abs=0.6), (vehicle["name"], t)
        assert script.pose_at(vehicle, float(track.t[0]) - 0.05) is None
        assert script.pose_at(vehicle, float(track.t[-1]) + 0.05) is None
    # between two samples: where the ego drove at 10 m/s from x = 5 m
    assert script.pose_at(by_name["hero"], 0.05)[0] == pytest.approx(5.5)
    assert len(by_name["v2"]["t"]) > 5  # the lane change keeps its curve


def test_the_scripts_frame_conversions_turn_the_right_way(script):
    # heading 90 deg (north, +y in OpenDRIVE) is yaw -90 in CARLA, y flipped
    assert script.to_carla(1.0, 2.0, math.pi / 2) == pytest.approx((1.0, -2.0, -90.0))
    # a box centre 1.5 m ahead of the origin: the origin is 1.5 m behind the pose
    assert script.origin_for_centre(10.0, 5.0, 0.0, (1.5, 0.0)) == pytest.approx((8.5, 5.0))
    assert script.origin_for_centre(10.0, 5.0, 90.0, (1.5, 0.0)) == pytest.approx((10.0, 3.5))
    # 0.2 m to the right (CARLA's +y at yaw 0): the origin 0.2 m to the left
    assert script.origin_for_centre(0.0, 0.0, 0.0, (0.0, 0.2)) == pytest.approx((0.0, -0.2))
    spans = [[0.0, 4.0, "green"], [4.0, 5.0, "yellow"], [5.0, 9.0, "red"]]
    assert [script.light_state_at(spans, t) for t in (0.0, 4.5, 8.9, 9.5)] == \
        ["green", "yellow", "red", None]


def test_the_carla_lint_says_the_trajectories_are_only_partly_supported(in_situ_scene):
    doc = ScenarioDoc(etree.parse(str(in_situ_scene / "in_situ" / "scenario.xosc")))
    found = carla_lint(doc)
    assert [f.code for f in found if f.severity == "error"] == []
    (partial,) = [f for f in found if f.code == "CARLA_PARTIAL"]
    assert partial.severity == "warning" and "Story" in partial.message
    # the same action in Init, or as a Clothoid, is not played by scenario_runner
    root = doc.root
    action = next(root.iter("FollowTrajectoryAction"))
    action.find(".//Polyline").tag = "Clothoid"
    codes = [f.code for f in carla_lint(ScenarioDoc(etree.ElementTree(root)))
             if f.severity == "error"]
    assert codes == ["CARLA_UNSUPPORTED"]


def carla_positions(world_map, carla, xs, ys, headings) -> float:
    """Share of the positions (OpenDRIVE frame), converted by the replay script's own
    ``to_carla``, that CARLA puts on a driving lane without projecting them onto the road."""
    to_carla = rendered_script()["to_carla"]
    hits = 0
    for x, y, h in zip(xs, ys, headings, strict=True):
        cx, cy, _ = to_carla(float(x), float(y), float(h))
        found = world_map.get_waypoint(carla.Location(x=cx, y=cy, z=0.0),
                                       project_to_road=False, lane_type=carla.LaneType.Driving)
        hits += found is not None
    return hits / len(xs)


def rendered_script() -> dict:
    """The replay script as ``scenweave export`` writes it, run as a module (not as the main
    program: it then only defines its functions)."""
    namespace: dict = {"__name__": "replay_in_carla", "__file__": "replay_in_carla.py"}
    exec(compile(replay_script("test", "test", 0.1), "replay_in_carla.py", "exec"), namespace)
    return namespace


def nan_waypoints(world_map) -> tuple[int, int]:
    waypoints = world_map.generate_waypoints(2.0)
    bad = sum(not all(math.isfinite(v) for v in (w.transform.location.x, w.transform.location.y,
                                                  w.transform.rotation.yaw)) for w in waypoints)
    return len(waypoints), bad


@needs_carla
def test_carla_parses_the_exported_map_and_the_record_lies_on_its_driving_lanes(carla_export,
                                                                               script):
    import carla

    world_map = carla.Map("in_situ", (carla_export / "road.xodr").read_text())
    count, bad = nan_waypoints(world_map)
    assert count > 50 and bad == 0
    scene = script.json.loads(script.TRAJECTORIES.read_text())
    for vehicle in scene["vehicles"]:
        share = carla_positions(world_map, carla, vehicle["x"], vehicle["y"], vehicle["heading"])
        assert share == 1.0, vehicle["name"]


#: recorded positions CARLA must put on a driving lane: pooled per location (a lane's
#: recorded vehicles cut corners at urban junctions), and per file
ON_LANE = {"us101": 0.995, "lankershim": 0.985, "peachtree": 0.98}
ON_LANE_PER_FILE = 0.96


@needs_carla
def test_carla_parses_every_shared_map_and_the_recorded_traffic_lies_on_driving_lanes(
        tmp_path):
    import carla

    from scenweave.mining.readers import read_recordings
    from scenweave.mining.recorded_road import road_for
    from tests.mining.conftest import shared_data

    folder = shared_data()
    files = sorted((folder / "ngsim").rglob("*.xml")) if folder else []
    if not files:
        pytest.skip("no shared NGSIM CommonRoad files here")
    pooled: dict[str, list[float]] = {}
    for file in files:
        road = road_for(file, tmp_path / "cache")
        world_map = carla.Map(file.stem, road.xodr.read_text(encoding="utf-8"))
        count, bad = nan_waypoints(world_map)
        assert count > 0 and bad == 0, (file.name, bad, count)
        (recorded,) = read_recordings(file)
        xs, ys, hs = (np.concatenate([getattr(t, k) for t in recorded.tracks])
                      for k in ("x", "y", "heading"))
        share = carla_positions(world_map, carla, xs, ys, hs)
        print(f"{file.name}: {count} waypoints, 0 NaN, {100 * share:.2f} % of {len(xs)} "
              "recorded positions on a driving lane")
        assert share >= ON_LANE_PER_FILE, (file.name, share)
        pooled.setdefault(file.parent.name, []).extend([share * len(xs), len(xs)])
    for location, counts in pooled.items():
        share = sum(counts[::2]) / sum(counts[1::2])
        print(f"{location}: {100 * share:.2f} % of {int(sum(counts[1::2]))} on a driving lane")
        assert share >= ON_LANE.get(location, 0.98), (location, share)


@needs_carla
def test_the_scripts_transforms_put_each_box_centre_on_its_record_on_carlas_road(carla_export,
                                                                                 script):
    """The script's transform_at with CARLA's own Map, Transform and BoundingBox (no server):
    an actor whose box centre lies 1.2 m ahead of its origin is put 1.2 m behind the recorded
    centre along its yaw, on the road's height."""
    import carla

    world_map = carla.Map("in_situ", (carla_export / "road.xodr").read_text())

    class Parked:  # what transform_at reads of an actor: its bounding box
        bounding_box = carla.BoundingBox(carla.Location(x=1.2, y=0.0, z=0.7),
                                         carla.Vector3D(2.3, 0.95, 0.7))

    scene = script.json.loads(script.TRAJECTORIES.read_text())
    for vehicle in scene["vehicles"]:
        for k in range(0, len(vehicle["t"]), 3):
            pose = (vehicle["x"][k], vehicle["y"][k], vehicle["heading"][k])
            placed = script.transform_at(carla, world_map, Parked(), pose)
            yaw = math.radians(placed.rotation.yaw)
            centre = (placed.location.x + 1.2 * math.cos(yaw),
                      placed.location.y + 1.2 * math.sin(yaw))
            assert centre == pytest.approx((pose[0], -pose[1]), abs=1e-3)
            assert placed.rotation.yaw == pytest.approx(-math.degrees(pose[2]), abs=1e-3)
            assert abs(placed.location.z - 0.05) < 0.01  # the fixture road is flat at z = 0


#: what replay_in_carla.py calls of CARLA's client API, by the class that has it
CARLA_API = {"Client": ("generate_opendrive_world", "get_world", "set_timeout"),
             "World": ("get_settings", "apply_settings", "tick", "spawn_actor", "get_map",
                       "get_blueprint_library", "get_spectator", "get_actors"),
             "WorldSettings": ("synchronous_mode", "fixed_delta_seconds"),
             "Actor": ("set_transform", "set_simulate_physics", "destroy", "get_transform",
                       "bounding_box"),
             "Map": ("get_waypoint",), "BlueprintLibrary": ("filter",),
             "ActorBlueprint": ("has_attribute", "set_attribute"), "ActorList": ("filter",),
             "TrafficLight": ("set_state", "freeze", "get_opendrive_id"),
             "TrafficLightState": ("Green", "Yellow", "Red", "Off")}


@needs_carla
def test_everything_the_script_calls_is_in_carlas_client_package(script):
    """Without a server the calls cannot run; the installed client package (the server's
    version) has each of them, and takes the script's road mesh parameters."""
    import carla

    text = Path(script.__file__).read_text()
    for owner, names in CARLA_API.items():
        for name in names:
            # the list is what the script calls (a light's state by its name)
            assert f".{name}" in text or f'"{name}"' in text, name
            assert hasattr(getattr(carla, owner), name), f"carla.{owner}.{name}"
    parameters = carla.OpendriveGenerationParameters(**script.MESH)
    assert parameters.wall_height == script.MESH["wall_height"]

"""Every reference script writes a valid OpenSCENARIO 1.0 file whose numbers are the params'.

What the file must contain is restated from docs/scenario-conventions.md in
``tests/corpus/conventions.py``, independently of the scenario library, so a convention changed on
one side only makes these tests fail.
"""

from __future__ import annotations

import ast
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from lxml import etree
from scenariogeneration import xosc

from scenweave import corpus, maneuvers
from scenweave.errors import ParamsError
from scenweave.scenario_lib import builder
from tests.corpus.conventions import (
    action_named,
    assert_entities_match,
    assert_storyboard_matches,
    first_difference,
)
from tests.corpus.params_examples import HIGHWAY_CLASSES, TAGS, example_params

ALL_CLASSES = list(TAGS)


def _write(code: str, tmp_path: Path, **changes) -> tuple[dict, etree._ElementTree]:
    params = example_params(code) | changes
    path = corpus.generate(params, tmp_path / f"{code}.xosc")
    return params, etree.parse(str(path))


@pytest.mark.parametrize("code", ALL_CLASSES)
def test_scenario_validates_against_the_1_0_xsd(code, tmp_path, xsd_1_0):
    _, doc = _write(code, tmp_path)
    assert xsd_1_0.validate(doc), xsd_1_0.error_log
    header = doc.find("FileHeader")
    assert (header.get("revMajor"), header.get("revMinor")) == ("1", "0")
    assert doc.find("RoadNetwork/LogicFile").get("filepath") == "Town04"


@pytest.mark.parametrize("code", ALL_CLASSES)
def test_scenario_round_trips_through_the_scenariogeneration_parser(code, tmp_path):
    path = corpus.generate(example_params(code), tmp_path / "a.xosc")
    parsed = xosc.ParseOpenScenario(str(path))
    rewritten = etree.fromstring(ET.tostring(parsed.get_element(), encoding="utf-8"))
    assert first_difference(rewritten, etree.parse(str(path)).getroot()) is None


@pytest.mark.parametrize("code", ALL_CLASSES)
def test_entities_and_init_carry_the_spawn_and_start_speeds(code, tmp_path):
    p, doc = _write(code, tmp_path)
    assert_entities_match(doc, p)


@pytest.mark.parametrize("code", ALL_CLASSES)
def test_storyboard_events_carry_the_params(code, tmp_path):
    p, doc = _write(code, tmp_path)
    assert_storyboard_matches(doc, p)


@pytest.mark.parametrize(("code", "direction", "sign"),
                         [("CINF", "right", -1), ("COUTB", "left", 1), ("LCB", "left", 1)])
def test_lane_change_goes_to_the_recorded_side(code, direction, sign, tmp_path):
    _, doc = _write(code, tmp_path, lane_change_direction=direction)
    entity = "hero" if code.startswith("LC") else "npc"
    target = action_named(doc, f"{entity}_lane_change").find(".//RelativeTargetLane")
    assert int(target.get("value")) == sign
    assert target.get("entityRef") == entity


def test_pass_on_green_keeps_the_light_green(tmp_path):
    _, doc = _write("U4_2", tmp_path, tfl_state="green")
    states = [s.get("state") for s in doc.findall(".//TrafficSignalStateAction")]
    assert states == ["green"]


def test_right_turn_target_lies_ahead_and_to_the_right_of_the_ego(tmp_path):
    p, doc = _write("U4_4", tmp_path)
    target = action_named(doc, "hero_turn_right").find(".//WorldPosition")
    dx, dy = float(target.get("x")) - p["ego_x"], float(target.get("y")) - p["ego_y"]
    heading = p["ego_h"]
    ahead = dx * math.cos(heading) + dy * math.sin(heading)
    right = dx * math.sin(heading) - dy * math.cos(heading)
    assert ahead > p["spawn_stop_line_distance_m"]
    assert right > 0


@pytest.mark.parametrize("weather", ["Day_Clear", "Day_Cloudy", "Day_Rain", "Night_Clear",
                                     "Night_Rain"])
def test_weather_key_names_the_environment(weather, tmp_path, xsd_1_0):
    _, doc = _write("FLF", tmp_path, weather_key=weather)
    assert xsd_1_0.validate(doc)
    environment = doc.find("Storyboard/Init/Actions/GlobalAction/EnvironmentAction/Environment")
    assert environment.get("name") == weather
    rain = environment.find("Weather/Precipitation").get("precipitationType")
    assert (rain == "rain") == weather.endswith("Rain")
    hour = environment.find("TimeOfDay").get("dateTime")[11:13]
    assert (hour == "22") == weather.startswith("Night")


def test_same_params_give_byte_identical_files(tmp_path):
    first = corpus.generate(example_params("CINB"), tmp_path / "a.xosc").read_bytes()
    second = corpus.generate(example_params("CINB"), tmp_path / "b.xosc").read_bytes()
    assert first == second


def test_write_is_atomic_and_creates_the_folder(tmp_path):
    out = tmp_path / "new" / "folder" / "s.xosc"
    corpus.generate(example_params("BRAKE"), out)
    assert [f.name for f in out.parent.iterdir()] == ["s.xosc"]


def test_missing_param_names_the_key_and_the_scenario(tmp_path):
    params = example_params("CINF")
    del params["npc_speed_ms"]
    with pytest.raises(ParamsError, match=r"CINF_example_row000007.*npc_speed_ms"):
        corpus.generate(params, tmp_path / "x.xosc")
    assert not list(tmp_path.iterdir())


def test_bad_direction_is_a_clear_error(tmp_path):
    params = example_params("LCF") | {"lane_change_direction": "up"}
    with pytest.raises(ParamsError, match="lane_change_direction"):
        corpus.generate(params, tmp_path / "x.xosc")


@pytest.mark.parametrize("script", corpus.list_scripts(), ids=lambda p: p.stem)
def test_scripts_import_only_the_scenario_library(script):
    """They also run in the sandbox, where only ``scenario_lib`` and scenariogeneration exist."""
    tree = ast.parse(script.read_text(encoding="utf-8"))
    modules = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    modules |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                for alias in node.names}
    assert modules <= {"scenweave.scenario_lib.builder", "pathlib"}
    assert ast.get_docstring(tree)
    assert any(isinstance(n, ast.FunctionDef) and n.name == "generate" for n in tree.body)


def test_the_builder_imports_nothing_else_from_scenweave():
    source = Path(builder.__file__).read_text(encoding="utf-8")
    tree = ast.parse(source)
    modules = {node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    modules |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                for alias in node.names}
    ours = {name for name in modules if name.split(".")[0] == "scenweave"}
    assert ours and all(name.startswith("scenweave.scenario_lib.") for name in ours), ours


def test_there_is_a_script_for_every_class():
    names = {path.name for path in corpus.list_scripts()}
    assert names == {Path(m.script).name for m in maneuvers.maneuvers()}
    for code in HIGHWAY_CLASSES:
        assert corpus.retrieve(code).script_path.name in names


@pytest.mark.parametrize(("code", "key"), [("BRAKE", "npc_s"), ("U4_1", "ego_x"),
                                           ("U4_2", "tfl_x_carla"), ("U4_4", "turn_exit_x"),
                                           ("U4_1", "spawn_stop_line_distance_m")])
def test_unfilled_spawn_key_is_a_clear_error(code, key, tmp_path):
    params = example_params(code) | {key: None}
    with pytest.raises(ParamsError, match=rf"'{key}' must be a finite number.*spawn_db"):
        corpus.generate(params, tmp_path / "x.xosc")


def test_nan_speed_is_refused(tmp_path):
    params = example_params("FLF") | {"npc_end_speed_ms": float("nan")}
    with pytest.raises(ParamsError, match="npc_end_speed_ms"):
        corpus.generate(params, tmp_path / "x.xosc")


SANDBOX_RUN = """
import importlib.abc, importlib.machinery, importlib.util, json, sys
LIB, SCRIPT = sys.argv[1], sys.argv[2]
OTHERS = {"ingest", "agent", "sandbox", "schemas", "spawn_db", "player", "roads", "corpus",
          "tests"}
class OnlyTheLibrary(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "scenweave":  # as in the sandbox: a namespace that holds only the library
            spec = importlib.machinery.ModuleSpec(name, None, is_package=True)
            spec.submodule_search_locations = [LIB + "/scenweave"]
            return spec
        inside = (name.startswith("scenweave.")
                  and not name.startswith("scenweave.scenario_lib"))
        if inside or name.split(".")[0] in OTHERS:
            raise ImportError(f"the sandbox has no {name}")
sys.meta_path.insert(0, OnlyTheLibrary())
from scenweave.scenario_lib import builder
assert builder.__file__.startswith(LIB), builder.__file__
spec = importlib.util.spec_from_file_location("llm_script", SCRIPT)  # as the harness does
script = importlib.util.module_from_spec(spec)
spec.loader.exec_module(script)
print(script.generate(json.loads(sys.argv[3]), sys.argv[4]))
"""


@pytest.mark.parametrize("code", ["CINF", "FRB", "U4_4"])
def test_a_reference_script_runs_with_a_copy_of_the_scenario_library_alone(
        code, tmp_path, xsd_1_0):
    """As in the sandbox: only ``scenweave/scenario_lib`` and scenariogeneration are there,
    and the script is a file of its own (not a module of the corpus)."""
    import json
    import shutil
    import subprocess
    import sys

    shutil.copytree(Path(builder.__file__).parent, tmp_path / "scenweave" / "scenario_lib",
                    ignore=shutil.ignore_patterns("__pycache__"))
    script = shutil.copy(corpus.retrieve(code).script_path, tmp_path / "script.py")
    out = tmp_path / "out" / "s.xosc"
    run = subprocess.run(
        [sys.executable, "-c", SANDBOX_RUN, str(tmp_path), str(script),
         json.dumps(example_params(code)), str(out)],
        cwd=tmp_path, env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"},
        capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert xsd_1_0.validate(etree.parse(str(out)))


#: what scenario_runner supports for OpenSCENARIO 1.0 (its Docs/openscenario_support.md)
CARLA_INIT_ACTIONS = {"TeleportAction", "SpeedAction", "EnvironmentAction"}
CARLA_STORY_ACTIONS = {"SpeedAction", "LaneChangeAction", "AcquirePositionAction",
                       "TrafficSignalStateAction"}
CARLA_CONDITIONS = {"SimulationTimeCondition"}


def _action_kinds(actions: list[etree._Element]) -> set[str]:
    kinds = set()
    for action in actions:
        node = action
        while len(node) == 1 and node[0].tag in (
                "PrivateAction", "GlobalAction", "LongitudinalAction", "LateralAction",
                "RoutingAction", "InfrastructureAction", "TrafficSignalAction"):
            node = node[0]
        kinds.add(node[0].tag)
    return kinds


@pytest.mark.parametrize("code", ALL_CLASSES)
def test_only_actions_and_conditions_scenario_runner_supports(code, tmp_path):
    _, doc = _write(code, tmp_path)
    init = doc.findall("Storyboard/Init/Actions/Private/PrivateAction")
    init += doc.findall("Storyboard/Init/Actions/GlobalAction")
    assert _action_kinds(init) <= CARLA_INIT_ACTIONS
    assert _action_kinds(doc.findall(".//Story//Action")) <= CARLA_STORY_ACTIONS
    conditions = {c[0][0].tag for c in doc.iter("Condition")}
    assert conditions <= CARLA_CONDITIONS
    for target in doc.iter("LaneChangeTarget"):
        assert target[0].tag == "RelativeTargetLane"  # the only target scenario_runner reads


def test_lane_ids_are_written_as_integers(tmp_path):
    _, doc = _write("BRAKE", tmp_path, ego_lane_id=-3.0, ego_road_id=45.0)
    position = doc.find("Storyboard/Init/Actions/Private[@entityRef='hero']//LanePosition")
    assert (position.get("laneId"), position.get("roadId")) == ("-3", "45")
    with pytest.raises(ParamsError, match="ego_lane_id"):
        _write("BRAKE", tmp_path, ego_lane_id=-2.5)

"""The player's process model (``player.engine``): a lean server forks one child per scenario.

The caller's ``__main__`` is not imported again per replay (a ``multiprocessing`` forkserver
child does), a crash, a hang or a dead server costs one playback (``engine_error``) and never
the next one, and a forked caller gets a server of its own.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from scenweave import roads
from scenweave.player import ReplaySettings, engine, replay_file

ROOT = Path(__file__).resolve().parents[2]
MAP = roads.DEFAULT_MAP_PATH

SCENARIO = """<?xml version="1.0" encoding="utf-8"?>
<OpenSCENARIO>
  <FileHeader description="engine test" author="test" revMajor="1" revMinor="0"
              date="2026-01-01T00:00:00"/>
  <ParameterDeclarations/>
  <CatalogLocations/>
  <RoadNetwork><LogicFile filepath="{map}"/></RoadNetwork>
  <Entities>
    <ScenarioObject name="hero">
      <Vehicle name="car" vehicleCategory="car">
        <BoundingBox><Center x="1.4" y="0" z="0.75"/>
          <Dimensions width="2" length="4.5" height="1.5"/></BoundingBox>
        <Performance maxSpeed="50" maxAcceleration="10" maxDeceleration="10"/>
        <Axles>
          <FrontAxle maxSteering="0.5" wheelDiameter="0.7" trackWidth="1.8" positionX="2.8"
                     positionZ="0.35"/>
          <RearAxle maxSteering="0" wheelDiameter="0.7" trackWidth="1.8" positionX="0"
                    positionZ="0.35"/>
        </Axles>
        <Properties/>
      </Vehicle>
    </ScenarioObject>
  </Entities>
  <Storyboard>
    <Init><Actions><Private entityRef="hero">
      <PrivateAction><TeleportAction><Position>
        <LanePosition roadId="35" laneId="-2" s="100" offset="0"/>
      </Position></TeleportAction></PrivateAction>
      <PrivateAction><LongitudinalAction><SpeedAction>
        <SpeedActionDynamics dynamicsShape="step" value="0" dynamicsDimension="time"/>
        <SpeedActionTarget><AbsoluteTargetSpeed value="{speed}"/></SpeedActionTarget>
      </SpeedAction></LongitudinalAction></PrivateAction>
    </Private></Actions></Init>
    <StopTrigger><ConditionGroup>
      <Condition name="stop" delay="0" conditionEdge="none"><ByValueCondition>
        <SimulationTimeCondition value="{stop}" rule="greaterThan"/>
      </ByValueCondition></Condition>
    </ConditionGroup></StopTrigger>
  </Storyboard>
</OpenSCENARIO>
"""


pytestmark = pytest.mark.usefixtures("needs_esmini")


def _scenario(tmp_path: Path, stop: float = 2.0, map_name: str = "Town04",
              speed: float = 20.0) -> Path:
    path = tmp_path / f"scenario-{stop:g}-{speed:g}-{map_name.replace('/', '_')}.xosc"
    path.write_text(SCENARIO.format(map=map_name, stop=stop, speed=speed), encoding="utf-8")
    return path


def _plays(path: Path) -> None:
    playback = replay_file(path, MAP, ReplaySettings())
    assert playback.engine_error is None, playback.engine_error
    assert playback.times[-1] == pytest.approx(2.0, abs=0.06)
    speeds = playback.tracks["hero"]["speed"]
    assert speeds[-1] == pytest.approx(20.0)
    assert playback.timings_s["start"] < 1.0 and playback.timings_s["load"] > 0


def test_the_callers_main_module_is_imported_once_not_per_replay(tmp_path):
    script = tmp_path / "caller.py"
    script.write_text(
        "print('main module imported', flush=True)\n"
        "import sys\n"
        "from pathlib import Path\n"
        "if __name__ == '__main__':\n"
        "    import roads\n"
        "    from player import replay_file\n"
        "    for _ in range(3):\n"
        "        playback = replay_file(Path(sys.argv[1]), roads.DEFAULT_MAP_PATH)\n"
        "        assert playback.engine_error is None, playback.engine_error\n"
        "    print('replayed', flush=True)\n", encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, str(script), str(_scenario(tmp_path))], env=env,
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.count("main module imported") == 1, done.stdout
    assert "replayed" in done.stdout


def test_an_engine_failure_is_one_playbacks_error_and_the_next_replay_plays(tmp_path):
    missing = engine.play_xml(_scenario(tmp_path, map_name="/nonexistent/map.xodr").read_bytes(),
                              2.0)
    assert missing.engine_error and not missing.times
    _plays(_scenario(tmp_path))


def test_a_replay_past_the_wall_clock_limit_is_killed_and_the_next_one_plays(tmp_path):
    parked = _scenario(tmp_path, stop=3600.0, speed=0.0)  # an hour on a small cut
    playback = replay_file(parked, MAP, ReplaySettings(wall_time_s=0.3))
    assert "did not finish within 0.3 s" in (playback.engine_error or "")
    assert playback.timings_s["map_share"] < 0.2
    assert playback.timings_s["replays"] == 1  # a hang is not played again on the whole map
    _plays(_scenario(tmp_path))


def test_a_dead_server_costs_one_playback_at_most(tmp_path):
    path = _scenario(tmp_path)
    _plays(path)
    server = engine._server.process
    assert server is not None and server.poll() is None
    os.kill(server.pid, signal.SIGKILL)
    server.wait()
    first = replay_file(path, MAP, ReplaySettings())
    if first.engine_error:  # the dead server was noticed on this call
        assert "player server" in first.engine_error
    _plays(path)
    assert engine._server.process.pid != server.pid


def _play_in_child(path: str, answers) -> None:
    playback = replay_file(Path(path), MAP, ReplaySettings())
    answers.put((playback.engine_error, engine._server.process.pid))


def test_a_forked_caller_gets_its_own_server(tmp_path):
    path = _scenario(tmp_path)
    _plays(path)
    parent_server = engine._server.process.pid
    context = multiprocessing.get_context("fork")
    answers = context.Queue()
    child = context.Process(target=_play_in_child, args=(str(path), answers))
    child.start()
    error, child_server = answers.get(timeout=60)
    child.join(30)
    assert child.exitcode == 0 and error is None
    assert child_server != parent_server
    _plays(path)  # the parent's server still serves the parent
    assert engine._server.process.pid == parent_server

"""The bulk recorder (``player.recorder``) and the forked-ahead player child (``player.engine``).

The recorder must give the playback the per-step recording gave, value for value: both record
the same real esmini run side by side in a child process (esmini's global state never enters
the test process), from a buffer too small at first so that it has to grow. The standby child
the server forks ahead must not outlive a server that is killed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from scenweave import roads
from scenweave.player import ReplaySettings, engine, find_esmini, replay_file
from tests.player.test_engine_server import SCENARIO

ROOT = Path(__file__).resolve().parents[2]

#: esmini plays the scenario in this child, recording each step both ways
SIDE_BY_SIDE = """
import ctypes, json, sys
from scenweave.player import engine
from scenweave.player.playback import Playback
from scenweave.player.recorder import StateRecorder

lib = engine._load(sys.argv[1])
args = [b"esmini", b"--osc", sys.argv[2].encode(), b"--headless", b"--fixed_timestep", b"0.05",
        b"--collision", b"--disable_stdout", b"--disable_log"]
assert lib.SE_InitWithArgs(len(args), (ctypes.c_char_p * len(args))(*args)) == 0
ids = [lib.SE_GetId(i) for i in range(lib.SE_GetNumberOfObjects())]
names = {i: lib.SE_GetObjectName(i).decode() for i in ids}
bulk = StateRecorder(lib, engine.ObjectState, ids, names, steps=1)  # grows as it records
per_step = Playback.empty(names.values())
state = engine.ObjectState()
while lib.SE_GetSimulationTime() < 3.0 - 1e-9:
    bulk.record()
    per_step.times.append(round(lib.SE_GetSimulationTime(), 4))
    for object_id, name in names.items():
        lib.SE_GetObjectState(object_id, ctypes.addressof(state))
        per_step.add_state(name, state)
    lib.SE_StepDT(0.05)
lib.SE_Close()
print(json.dumps([bulk.playback().to_dict(), per_step.to_dict()]))
"""


pytestmark = pytest.mark.usefixtures("needs_esmini")


def _two_cars(tmp_path: Path) -> Path:
    """The engine test's scenario with a second car behind the first, slower."""
    text = SCENARIO.format(map=roads.DEFAULT_MAP_PATH, stop=3.0, speed=20.0)
    second = text[text.index("<ScenarioObject"):text.index("</ScenarioObject>") + 17]
    text = text.replace("</Entities>", second.replace('"hero"', '"npc"') + "</Entities>")
    init = text[text.index('<Private entityRef="hero">'):text.index("</Private>") + 10]
    moved = init.replace('"hero"', '"npc"').replace('s="100"', 's="70"')
    text = text.replace("</Private></Actions>", "</Private>" + moved.replace(
        'value="20.0"', 'value="14"') + "</Actions>", 1)
    path = tmp_path / "two.xosc"
    path.write_text(text, encoding="utf-8")
    return path


def test_bulk_recording_is_the_per_step_recording_value_for_value(tmp_path):
    done = subprocess.run([sys.executable, "-c", SIDE_BY_SIDE, str(find_esmini().library),
                           str(_two_cars(tmp_path))], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    bulk, per_step = json.loads(done.stdout.strip().splitlines()[-1])
    assert set(bulk["tracks"]) == {"hero", "npc"}
    assert len(bulk["times"]) == 60 and bulk["times"] == per_step["times"]
    assert bulk["tracks"] == per_step["tracks"]
    assert bulk["boxes"] == per_step["boxes"]
    hero, npc = bulk["tracks"]["hero"], bulk["tracks"]["npc"]
    assert hero["speed"][-1] == pytest.approx(20.0) and npc["speed"][-1] == pytest.approx(14.0)
    assert hero["s"][-1] > npc["s"][-1] + 30  # not one car's column read twice


def _children(pid: int) -> list[int]:
    """The live (not zombie) children of ``pid``."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        for child in (task / "children").read_text().split():
            try:
                state = Path(f"/proc/{child}/stat").read_text().rsplit(")", 1)[1].split()[0]
            except (OSError, IndexError):
                continue
            if state != "Z":
                found.append(int(child))
    return found


def _standby_of(server: int) -> int:
    """The server's child waiting for the next scenario: its one live child, the same on two
    looks 0.3 s apart (the last scenario's child is reaped before it is forked)."""
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        first = _children(server)
        time.sleep(0.3)
        if len(first) == 1 and _children(server) == first:
            return first[0]
    raise AssertionError(f"no child waiting under the player server {server}")


def test_the_child_forked_ahead_ends_with_a_killed_server(tmp_path):
    path = tmp_path / "one.xosc"
    path.write_text(SCENARIO.format(map="Town04", stop=1.0, speed=10.0), encoding="utf-8")
    assert replay_file(path, roads.DEFAULT_MAP_PATH, ReplaySettings()).engine_error is None
    server = engine._server.process
    assert server is not None
    standby = _standby_of(server.pid)
    os.kill(server.pid, signal.SIGKILL)
    server.wait()
    deadline = time.monotonic() + 10
    while Path(f"/proc/{standby}").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = Path(f"/proc/{standby}/status")
    assert not alive.exists() or "zombie" in alive.read_text()
    replay_file(path, roads.DEFAULT_MAP_PATH)  # may be the one that finds the server gone
    assert replay_file(path, roads.DEFAULT_MAP_PATH).engine_error is None


def test_a_child_killed_while_it_waits_costs_one_playback(tmp_path):
    path = tmp_path / "one.xosc"
    path.write_text(SCENARIO.format(map="Town04", stop=1.0, speed=10.0), encoding="utf-8")
    assert replay_file(path, roads.DEFAULT_MAP_PATH).engine_error is None
    server = engine._server.process
    assert server is not None
    os.kill(_standby_of(server.pid), signal.SIGKILL)
    prepared = SCENARIO.format(map=roads.DEFAULT_MAP_PATH, stop=1.0, speed=10.0).encode()
    lost = engine.play_xml(prepared, 1.0)  # not replay_file, which would play it again
    assert "SIGKILL" in (lost.engine_error or ""), lost.engine_error
    assert engine._server.process is server  # the server itself carried on
    assert replay_file(path, roads.DEFAULT_MAP_PATH).engine_error is None

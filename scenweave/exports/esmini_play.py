"""One play of an exported scenario with esmini's command-line player, as a plain esmini user
runs it: recorded into ``replay.dat`` beside the scenario, judged by esmini's own log."""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

#: esmini's recording of one play, beside the scenario
RECORDING_NAME = "replay.dat"
#: esmini's log of that play, beside the scenario
LOG_NAME = "esmini.log"
#: seconds one esmini run may take before it is stopped
WALL_TIME_S = 120
#: esmini's log line when the storyboard has run to its stop trigger
STORY_COMPLETE = "storyBoard runningState -> stopTransition -> completeState"
#: what esmini 3.6 logs as [error] while reading a map, harmless for playing: CARLA's maps
#: (the geo reference's proj string, CARLA's object types, signal references) and the
#: converted recorded roads (a road without a <type> record: esmini then takes its junctions
#: for intersections in OSI)
MAP_LOAD_NOTES = ("Unsupported geo reference attr", "Unsupported object type",
                  'signal element "signalReference" not supported', "Type of roads are missing")


def record_play(esmini: Path, scenario: Path, step_s: float,
                extra_args: Sequence[str] = ()) -> str | None:
    """Play ``scenario`` once headless at a fixed ``step_s``, recording ``replay.dat`` beside
    it; a line naming the problem when esmini failed, timed out or did not complete the
    storyboard, else None."""
    command = [str(esmini), "--headless", "--osc", scenario.name, "--fixed_timestep",
               f"{step_s:g}", *extra_args, "--record", RECORDING_NAME, "--logfile_path", LOG_NAME]
    try:
        done = subprocess.run(command, cwd=scenario.parent, capture_output=True, text=True,
                              timeout=WALL_TIME_S, check=False)
    except subprocess.TimeoutExpired:
        return f"{scenario}: esmini did not finish within {WALL_TIME_S} s"
    lines = _read_lines(scenario.with_name(LOG_NAME))
    errors = [line for line in lines if "[error]" in line
              and not any(note in line for note in MAP_LOAD_NOTES)]
    recording = scenario.with_name(RECORDING_NAME)
    if recording.is_file():
        recording.chmod(0o644)
    if done.returncode != 0 or errors or not recording.is_file() \
            or not any(STORY_COMPLETE in line for line in lines):
        detail = "; ".join(errors[:3]) or done.stderr.strip()[-300:] or \
            f"exit {done.returncode}, the storyboard did not complete"
        return f"{scenario}: esmini failed: {detail}"
    return None


def _read_lines(path: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []

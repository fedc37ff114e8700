"""The in-situ scenario of a mined event (``<scenario>/in_situ/``: ``scenario.xosc`` on its
recorded road ``road.xodr``) for other people's tools.

For esmini (:func:`export_esmini`): the scenario unchanged with the road beside it. Its
``LogicFile`` already names ``road.xodr`` relative to the scenario and its lights are
TrafficSignalControllers on the road's own signal ids, so plain ``esmini --osc
scenario.xosc`` plays it from anywhere; it is played once to record ``replay.dat`` (with
``--traj_filter 0``, as ScenWeave's player plays it: esmini's default merges vertices closer
than 0.1 m, which makes a creeping car jump).

For CARLA (:func:`export_carla`): the road for CARLA's OpenDRIVE standalone mode and a replay
path CARLA supports. scenario_runner takes ``FollowTrajectoryAction`` in the Story only and
as a Polyline only, its following left to a controller (its support table still marks the
action unsupported: ``judge.carla_lint``), so the folder also holds ``replay_in_carla.py``, a
readable client script made from ``replay_in_carla.py.txt`` that loads the road with
``client.generate_opendrive_world``, and every tick in synchronous mode sets each recorded
vehicle's transform (CARLA's frame: y flipped, yaw = -heading in degrees), the ego optionally
left to the user's stack; its data is ``trajectories.json`` (what the scenario plays, read by
``judge.in_situ_doc``).
"""

from __future__ import annotations

import json
import shutil
import string
from pathlib import Path
from typing import Any

from scenweave.exports.esmini_play import RECORDING_NAME, record_play
from scenweave.files import write_text_atomic
from scenweave.judge.in_situ_doc import (
    InSituDoc,
    is_in_situ,
    read_in_situ,
)
from scenweave.schemas.scenario_folder import (
    HERO_REFERENCE_NAME,
    IN_SITU_CHOICE_NAME,
    ROAD_NAME,
    XOSC_NAME,
    read_json_object,
)

SCRIPT_NAME = "replay_in_carla.py"
TEMPLATE = Path(__file__).with_name(f"{SCRIPT_NAME}.txt")
TRAJECTORIES_NAME = "trajectories.json"
#: the CARLA lint's findings on the scenario, for a scenario_runner user
LINT_NAME = "carla_lint.txt"
README_NAME = "README.md"
#: decimals of the trajectories handed to CARLA: millimetres, 1e-5 rad, milliseconds
DIGITS = {"x": 3, "y": 3, "heading": 5, "t": 3}

__all__ = ["SCRIPT_NAME", "TRAJECTORIES_NAME", "export_carla", "export_esmini", "is_in_situ",
           "replay_script", "trajectories"]


def _copy(source: Path, target: Path) -> None:
    shutil.copyfile(source, target)
    target.chmod(0o644)


def _copy_scene(folder: Path, out: Path) -> InSituDoc:
    """The scenario, its road and what was chosen, copied into ``out``; the scenario read."""
    doc = read_in_situ(folder)
    out.mkdir(parents=True, exist_ok=True)
    for name in (XOSC_NAME, ROAD_NAME, IN_SITU_CHOICE_NAME, HERO_REFERENCE_NAME):
        if (folder / name).is_file():
            _copy(folder / name, out / name)
    return doc


# --- esmini ----------------------------------------------------------------------------------

def export_esmini(folder: Path, out: Path, esmini: Path) -> str | None:
    """Copy the in-situ scenario in ``folder`` with its road into ``out`` and record one play
    with ``esmini`` (the binary); a line naming the problem, if any."""
    doc = _copy_scene(folder, out)
    if doc.road_file != ROAD_NAME:
        return f"{doc.xosc}: its LogicFile names {doc.road_file!r}, not the {ROAD_NAME} beside it"
    return record_play(esmini, out / XOSC_NAME, _step_s(folder, doc),
                       extra_args=("--traj_filter", "0"))


def _step_s(folder: Path, doc: InSituDoc) -> float:
    """The recording's step (``in_situ.json``; 0.1 s for NGSIM and highD at 10 Hz), else the
    shortest step between two trajectory vertices (a trajectory keeps only the vertices a
    straight line between its neighbours would miss, so that one may be longer)."""
    recorded = read_json_object(folder / IN_SITU_CHOICE_NAME).get("step_s")
    if isinstance(recorded, int | float) and recorded > 0:
        return float(recorded)
    steps = [b - a for v in doc.vehicles for a, b in zip(v.times, v.times[1:], strict=False)]
    return round(min(steps), 3) if steps else 0.1


# --- CARLA -----------------------------------------------------------------------------------

def trajectories(doc: InSituDoc, source: str = "", step_s: float = 0.1) -> dict[str, Any]:
    """What the CARLA replay script plays: every vehicle's blueprint, size and recorded
    trajectory (OpenDRIVE frame: the script converts), the lights' recorded colours."""
    vehicles = [{"name": v.name, "blueprint": v.blueprint, "category": v.category,
                 "track_id": v.track_id, "external": v.external,
                 "length_m": v.length_m, "width_m": v.width_m, "height_m": v.height_m,
                 **{key: [round(value, DIGITS[key]) for value in values]
                    for key, values in (("t", v.times), ("x", v.x), ("y", v.y),
                                        ("heading", v.heading))}}
                for v in doc.vehicles]
    return {"source": source, "road": ROAD_NAME, "step_s": step_s,
            "duration_s": doc.duration_s, "vehicles": vehicles,
            "signals": {signal: [list(span) for span in spans]
                        for signal, spans in doc.signals.items()}}


def replay_script(title: str, source: str, step_s: float) -> str:
    """The CARLA replay script's text for one scenario."""
    def safe(text: str) -> str:  # it goes into the script's docstring
        return text.replace("\\", "/").replace('"""', "'''")

    return string.Template(TEMPLATE.read_text(encoding="utf-8")).substitute(
        title=safe(title), source=safe(source), step_s=f"{step_s:g}")


def export_carla(folder: Path, out: Path) -> InSituDoc:
    """Write the in-situ scenario in ``folder`` for CARLA into ``out``: the scenario, the road
    (for ``generate_opendrive_world``), ``trajectories.json`` and ``replay_in_carla.py``."""
    doc = _copy_scene(folder, out)
    choice = read_json_object(folder / IN_SITU_CHOICE_NAME)
    source = str(choice.get("file") or "")
    data = trajectories(doc, source, _step_s(folder, doc))
    write_text_atomic(out / TRAJECTORIES_NAME, json.dumps(data, separators=(",", ":")) + "\n")
    owner = folder.parent.name if folder.name == "in_situ" else folder.name
    title = (f"{owner}: ego track {choice.get('ego_track', '?')}, "
             f"{len(doc.vehicles)} recorded vehicles, {doc.duration_s:g} s")
    script = out / SCRIPT_NAME
    write_text_atomic(script, replay_script(title, source, data["step_s"]))
    script.chmod(0o755)
    write_text_atomic(out / LINT_NAME, lint_report(out / XOSC_NAME))
    return doc


def lint_report(xosc: Path) -> str:
    """What the CARLA lint says of the scenario for scenario_runner, one finding a line (its
    CARLA_PARTIAL warning on the trajectories is why the replay script is there)."""
    from lxml import etree

    from scenweave.judge.carla_lint import carla_lint
    from scenweave.judge.scenario_doc import ScenarioDoc

    found = carla_lint(ScenarioDoc(etree.parse(str(xosc))))
    lines = [f"{f.severity} {f.code}: {f.message}" for f in found]
    return "\n".join(lines or ["no finding: scenario_runner plays the scenario as written"]) + "\n"


# --- what the export's README says of them -----------------------------------------------------

def _listed(names: list[str]) -> str:
    return "\n".join(f"- `{name}/`" for name in names)


def esmini_readme_section(names: list[str]) -> str:
    """The esmini README's part on the in-situ scenarios exported under ``names``."""
    return f"""
## In situ: the event on its recorded road, with every recorded vehicle

{_listed(names)}

Each folder holds `{XOSC_NAME}` (every recorded vehicle follows its recorded trajectory:
FollowTrajectoryAction, Polyline with vertex times, absolute timing, position mode) with the
recorded road `{ROAD_NAME}` beside it, named relative to the scenario, so the folder plays
wherever it is copied:
```bash
esmini --headless --osc <folder>/{XOSC_NAME} --fixed_timestep 0.1 --traj_filter 0
```
`--traj_filter 0` keeps every recorded vertex (esmini merges vertices closer than 0.1 m by
default, so a creeping car would jump); without it the scenario plays all the same.
`{RECORDING_NAME}` is one play recorded that way.
"""


def carla_readme_section(names: list[str]) -> str:
    """The CARLA README's part on the in-situ scenarios exported under ``names``."""
    return f"""
## In situ: the event on its recorded road, with every recorded vehicle

{_listed(names)}

Each folder holds the recorded road `{ROAD_NAME}` for CARLA's OpenDRIVE standalone mode, the
scenario `{XOSC_NAME}`, `{TRAJECTORIES_NAME}` (every vehicle's recorded trajectory,
OpenDRIVE frame) and `{SCRIPT_NAME}`, a client script that replays them (CARLA server
running, the `carla` package of its version installed):
```bash
python <folder>/{SCRIPT_NAME}                  # every vehicle as recorded
python <folder>/{SCRIPT_NAME} --ego external   # your stack drives role_name "hero"
```
It loads the road with `client.generate_opendrive_world`, runs the world in synchronous mode
at the recording's step and sets every vehicle's transform each tick (CARLA's frame: y flipped,
yaw = -heading in degrees), spawning each when its track starts and removing it when it ends.

scenario_runner can open `{XOSC_NAME}` too (`LogicFile` names the `.xodr`, which it loads as a
standalone world), but it plays FollowTrajectoryAction only in the Story and as a Polyline, and
leaves the following to each actor's controller: the vehicles follow their records less
closely than in esmini (`{LINT_NAME}`: the CARLA lint's findings, `CARLA_PARTIAL` saying
this). The script is the replay as recorded.
"""

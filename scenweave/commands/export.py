"""``scenweave export RUN_DIR|FILE.xosc --for esmini|carla --out DIR``: scenarios that plain
esmini and CARLA users open with their own tools.

``--for esmini`` writes the copy the replay itself plays (``player.translate``: the map named
by file, each ``pos=x,y`` light by its OpenDRIVE signal id, lamp modes for its colours) with
the map prepared for esmini (``player.maps.esmini_map``) beside it, so
``esmini --headless --osc DIR/<scenario>/scenario.xosc`` plays it as is; each is played once
with esmini's command-line player recording ``replay.dat`` for esmini's own replayer, and a
scenario esmini refuses is named. ``--for carla`` copies the delivered files (CARLA's dialect)
with a README saying how scenario_runner plays them on their town.

A mined event's in-situ scenario (``<scenario>/in_situ/``, on its recorded road) goes to
``<scenario>/in_situ/`` of the export: for esmini the scenario with its ``road.xodr`` beside it
(and its recording), for CARLA the road for CARLA's OpenDRIVE standalone mode and a client
script that replays every recorded vehicle (``scenweave.exports.in_situ``).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import click

from scenweave.commands.replay import scenario_files
from scenweave.exports.esmini_play import RECORDING_NAME, record_play
from scenweave.schemas.scenario_folder import CODE_NAME, PARAMS_NAME, XOSC_NAME

MAPS_DIR = "maps"
README_NAME = "README.md"
#: the step esmini plays the exported copy with (the replay's own)
TIME_STEP_S = 0.05


@click.command("export")
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@click.option("--for", "target", required=True, type=click.Choice(["esmini", "carla"]),
              help="esmini: the copy plain esmini plays, its map and a .dat recording; "
                   "carla: the delivered files and how to run them with scenario_runner.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder to write into (one folder per scenario).")
def export(paths: tuple[Path, ...], target: str, out_dir: Path) -> None:
    """Export scenarios (a run folder's, or .xosc files) for esmini or CARLA."""
    from scenweave.exports.in_situ import is_in_situ

    found = scenario_files(paths)
    if not found:
        raise click.UsageError("no .xosc files found in " + ", ".join(map(str, paths)))
    out_dir.mkdir(parents=True, exist_ok=True)
    in_situ = {xosc: _in_situ_name(xosc) for xosc in found if is_in_situ(xosc.parent)}
    files = [xosc for xosc in found if xosc not in in_situ]
    names = _folder_names(files)
    if target == "carla":
        for xosc in files:
            _export_carla(xosc, out_dir / names[xosc])
        problems = _export_in_situ_carla(in_situ, out_dir)
        _write(out_dir / README_NAME, carla_readme(files, names, in_situ))
        click.echo(f"export: {len(found) - len(problems)}/{len(found)} scenarios for CARLA "
                   f"({len(in_situ)} in situ) -> {out_dir} ({README_NAME})")
        _fail(problems)
        return
    from scenweave.player import find_esmini

    esmini = find_esmini().home / "bin" / "esmini"
    problems = [p for xosc in files
                if (p := _export_esmini(xosc, out_dir, names[xosc], esmini)) is not None]
    problems += _export_in_situ_esmini(in_situ, out_dir, esmini)
    _write(out_dir / README_NAME, esmini_readme(list(in_situ.values())))
    click.echo(f"export: {len(found) - len(problems)}/{len(found)} scenarios play in plain "
               f"esmini ({len(in_situ)} in situ) -> {out_dir}")
    _fail(problems)


def _in_situ_name(xosc: Path) -> str:
    """Where an in-situ scenario goes: ``<scenario>/in_situ`` as a run's scenario folder holds
    it, or its own folder's name (``scenweave mine --in-situ`` names each by its record)."""
    folder = xosc.parent
    return f"{folder.parent.name}/{folder.name}" if folder.name == "in_situ" else folder.name


def _fail(problems: list[str]) -> None:
    for problem in problems:
        click.echo(f"FAIL {problem}")
    if problems:
        raise SystemExit(1)


def _export_in_situ_esmini(in_situ: dict[Path, str], out_dir: Path, esmini: Path) -> list[str]:
    """Each in-situ scenario with its road, played once; the problems."""
    from scenweave.exports.in_situ import export_esmini
    from scenweave.judge.in_situ_doc import InSituDocError

    problems = []
    for xosc, name in in_situ.items():
        try:
            problem = export_esmini(xosc.parent, out_dir / name, esmini)
        except InSituDocError as err:
            problem = str(err)
        if problem is not None:
            problems.append(problem)
    return problems


def _export_in_situ_carla(in_situ: dict[Path, str], out_dir: Path) -> list[str]:
    """Each in-situ scenario with its road and its CARLA replay script; the problems."""
    from scenweave.exports.in_situ import export_carla
    from scenweave.judge.in_situ_doc import InSituDocError

    problems = []
    for xosc, name in in_situ.items():
        try:
            export_carla(xosc.parent, out_dir / name)
        except InSituDocError as err:
            problems.append(str(err))
    return problems


def _folder_names(files: list[Path]) -> dict[Path, str]:
    """One folder name per scenario: its folder's name (a lone file: its stem), unique."""
    names: dict[Path, str] = {}
    for xosc in files:
        name = xosc.parent.name if xosc.name == XOSC_NAME else xosc.stem
        while name in names.values() or name == MAPS_DIR:
            name += "_"
        names[xosc] = name
    return names


# --- esmini ------------------------------------------------------------------------------------

def _export_esmini(xosc: Path, out_dir: Path, name: str, esmini: Path) -> str | None:
    """Write the esmini copy of ``xosc`` and its recording; a line naming the problem, if any."""
    from scenweave import roads
    from scenweave.player import TranslationError
    from scenweave.player.maps import esmini_map
    from scenweave.player.translate import translate

    map_path = _map_of(xosc)
    if map_path is None:
        return f"{xosc}: its LogicFile names no known map"
    map_copy = out_dir / MAPS_DIR / f"{map_path.stem}.xodr"
    if not map_copy.is_file():
        map_copy.parent.mkdir(exist_ok=True)
        shutil.copyfile(esmini_map(map_path), map_copy)
        map_copy.chmod(0o644)
    folder = out_dir / name
    folder.mkdir(exist_ok=True)
    try:
        # the map by a path relative to the scenario: the exported folder can be moved whole
        translated = translate(xosc.read_bytes(), Path("..") / MAPS_DIR / map_copy.name,
                               roads.traffic_lights_carla(map_path))
    except TranslationError as err:
        return f"{xosc}: {err}"
    scenario = folder / XOSC_NAME
    scenario.write_bytes(translated.xml)
    scenario.chmod(0o644)
    return record_play(esmini, scenario, TIME_STEP_S)


def _map_of(xosc: Path) -> Path | None:
    """The map the scenario is made for: its params' ``map``, else its ``LogicFile``."""
    import json

    from lxml import etree

    from scenweave.judge.scenario_doc import ScenarioDoc

    params_path = xosc.parent / PARAMS_NAME
    named = json.loads(params_path.read_text(encoding="utf-8")).get("map") \
        if params_path.is_file() else None
    try:
        return ScenarioDoc(etree.parse(str(xosc)), named).map_path
    except (OSError, etree.XMLSyntaxError):
        return None


def esmini_readme(in_situ: list[str] | None = None) -> str:
    from scenweave.exports.in_situ import esmini_readme_section

    return f"""# Scenarios for esmini

Each folder holds `scenario.xosc`, the copy ScenWeave's replay plays: the map is named by a
path relative to the scenario (`../{MAPS_DIR}/`, the map prepared for esmini: CARLA's
`value="-1"` dropped from its lights), each traffic light by its OpenDRIVE signal id, with lamp
modes for its colours. `{RECORDING_NAME}` is esmini's recording of one play, `esmini.log` its log.

```bash
esmini --window 60 60 800 400 --osc <scenario>/scenario.xosc   # watch it (a build with a viewer)
esmini --headless --osc <scenario>/scenario.xosc               # play it headless
replayer --file <scenario>/{RECORDING_NAME}                    # esmini's replayer (needs OSG)
dat2csv <scenario>/{RECORDING_NAME}                            # the recording as CSV
```
The delivered scenarios (CARLA's dialect) are unchanged; export them with `--for carla`.
""" + (esmini_readme_section(in_situ) if in_situ else "")


# --- CARLA -------------------------------------------------------------------------------------

DELIVERED = (XOSC_NAME, CODE_NAME, PARAMS_NAME)


def _export_carla(xosc: Path, folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    sources = [xosc.parent / n for n in DELIVERED] if xosc.name == XOSC_NAME else [xosc]
    for source in sources:
        if source.is_file():
            target = folder / (XOSC_NAME if source == xosc else source.name)
            shutil.copyfile(source, target)
            target.chmod(0o644)


def carla_readme(files: list[Path], names: dict[Path, str],
                 in_situ: dict[Path, str] | None = None) -> str:
    from lxml import etree

    from scenweave.exports.in_situ import carla_readme_section

    rows = []
    for xosc in files:
        logic = etree.parse(str(xosc)).find("RoadNetwork/LogicFile")
        town = logic.get("filepath") if logic is not None else "?"
        rows.append(f"| `{names[xosc]}/scenario.xosc` | {town} |")
    table = "\n".join(rows)
    return f"""# Scenarios for CARLA

Each folder holds the delivered `scenario.xosc` (OpenSCENARIO 1.0 in CARLA's dialect: the town
named in `RoadNetwork/LogicFile`, traffic lights as `pos=x,y` in CARLA's frame), the script
that made it (`scenario.py`) and the record's values (`params.json`).

| scenario | town |
|---|---|
{table}

Run one with CARLA's scenario_runner (a CARLA server running; scenario_runner loads the town
the file names):
```bash
./CarlaUE4.sh &                                     # the CARLA server
python scenario_runner.py --openscenario <scenario>/scenario.xosc --reloadWorld
```
A map given by file (not a CARLA town) is loaded as a standalone OpenDRIVE world by
scenario_runner when `LogicFile` holds the path to the `.xodr`; copy the map next to it.
""" + (carla_readme_section(list(in_situ.values())) if in_situ else "")


def _write(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8")
    path.chmod(0o644)

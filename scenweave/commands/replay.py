"""``scenweave replay RUN_DIR | FILE.xosc...``: play scenarios headless in esmini and judge them.

A scenario folder's ``params.json`` (the record's values) is what the replay is judged
against; a lone ``.xosc`` without one is only played (engine errors and collisions count).
Each played scenario gets its ``replay.json`` beside it; the delivered ``.xosc`` is not touched.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import json_option, map_option
from scenweave.progress import progress
from scenweave.schemas.scenario_folder import ATTEMPTS_DIR, PARAMS_NAME, XOSC_NAME

if TYPE_CHECKING:
    from scenweave.schemas.params import Params


@click.command("replay")
@click.argument("paths", nargs=-1, required=True,
                type=click.Path(exists=True, path_type=Path))
@click.option("--time-step", default=0.05, show_default=True, type=click.FloatRange(0.001, 1),
              help="Fixed simulation step (s).")
@click.option("--wall-time", default=30.0, show_default=True, type=click.FloatRange(1),
              help="Seconds one replay may take before its player is killed.")
@click.option("--figures", is_flag=True, help="Also draw replay.svg in each scenario folder.")
@json_option("one result per scenario")
@click.option("--force", is_flag=True, help="Play a file that fails the parameter checks too "
              "(a hand-edited scenario), and say which checks it fails.")
@map_option(optional=True, help="Map to play on instead of the one each scenario names (its "
                               "params' map, else its LogicFile): a bundled CARLA town or an "
                               ".xodr path.")
def replay(paths: tuple[Path, ...], time_step: float, wall_time: float, figures: bool,
           as_json: bool, force: bool, map_ref: Any) -> None:
    """Play each scenario (a run folder's, or .xosc files) and say whether it replays as
    recorded; exit status 1 when one does not."""
    from scenweave.player import ReplaySettings, find_esmini

    find_esmini()  # PlayerUnavailable is one line naming ESMINI_HOME
    settings = ReplaySettings(time_step_s=time_step, wall_time_s=wall_time)
    files = _without_in_situ(scenario_files(paths), quiet=as_json)
    if not files:
        raise click.UsageError("no .xosc files found in " + ", ".join(map(str, paths)))
    map_path = None if map_ref is None else map_ref.path
    later = play_unplayed_runs(paths, settings, map_path)
    results = [later.get(xosc) or replay_one(xosc, settings, figures, map_path, force)
               for xosc in progress(files, desc="replay")]
    for result in results:
        if result.get("forced") and not as_json:
            click.echo(f"FORCED {result['scenario']}: fails the parameter checks ("
                       + ", ".join(result["forced"]) + "); played anyway")
        if not as_json and not result["passed"]:
            click.echo(f"FAIL {result['scenario']}: " + "; ".join(result["errors"][:3]))
    passed = sum(r["passed"] for r in results)
    if as_json:
        click.echo(json.dumps(results, indent=1))
    else:
        click.echo(f"replay: {passed}/{len(results)} played as recorded")
    exit_codes.finish(passed < len(results))


def play_unplayed_runs(paths: tuple[Path, ...], settings: Any,
                       map_path: Path | None) -> dict[Path, dict]:
    """The delivered scenarios of the run folders named that were never played (``scenweave
    .unplayed``): played, each committed again with its replay (failed when it does not
    replay as recorded), the run's summary.json and report.html rewritten; by .xosc path."""
    from scenweave.presentation.report import write_run_report
    from scenweave.run_folder import RunFolder
    from scenweave.runner import summarize
    from scenweave.schemas.scenario_folder import RUN_FILE, SUMMARY_FILE, read_json_object
    from scenweave.unplayed import play_unplayed

    results: dict[Path, dict] = {}
    for path in paths:
        if not (path / RUN_FILE).is_file():
            continue
        folder = RunFolder(path)
        played = play_unplayed(folder, settings, map_path)
        for outcome in played:
            xosc = scenario_files((folder.scenario_dir(outcome["scenario_id"]),))
            results.update({file: _played_later(outcome) for file in xosc})
        if played:
            issues = read_json_object(path / SUMMARY_FILE).get("input_issues") or []
            folder.write(SUMMARY_FILE, summarize(folder, issues))
            write_run_report(folder.root)
    return results


def _played_later(outcome: dict) -> dict:
    """A scenario played by ``play_unplayed_runs`` as ``replay_one`` reports one."""
    replay = outcome.get("replay") or {}
    errors = (outcome.get("validation") or {}).get("errors") or [] \
        if outcome.get("status") == "failed" else []
    return {"scenario": outcome["scenario_id"], "played": bool(replay.get("played")),
            "passed": bool(replay.get("passed")) and not errors,
            "codes": sorted({e["code"] for e in errors} | set(replay.get("codes") or [])),
            "errors": [f"{e['code']}: {e.get('message', '')}" for e in errors]}


def _without_in_situ(files: list[Path], quiet: bool) -> list[Path]:
    """The scenarios to replay: not a mined event's in-situ scenario, which was played and
    judged against its recording when it was written (``in_situ/judge.json``); one line says
    how many were left as they are."""
    from scenweave.judge.in_situ_doc import is_in_situ

    kept = [xosc for xosc in files if not is_in_situ(xosc.parent)]
    if len(kept) < len(files) and not quiet:
        click.echo(f"replay: {len(files) - len(kept)} in-situ scenarios left as played when "
                   "written (judged against their recording in judge.json; scenweave view "
                   "shows them)", err=True)
    return kept


def scenario_files(paths: tuple[Path, ...]) -> list[Path]:
    """The ``.xosc`` files named, or found in the folders named (a run or a scenario folder)."""
    files: list[Path] = []
    for path in paths:
        if path.is_dir():
            files += sorted(p for p in path.rglob(XOSC_NAME)
                            if not any(part.startswith(".") or part == ATTEMPTS_DIR
                                       for part in p.relative_to(path).parts))
        elif path.suffix == ".xosc":
            files.append(path)
    return files


def replay_one(xosc: Path, settings, figures: bool, map_path: Path | None = None,
               force: bool = False) -> dict:
    """Play ``xosc`` (on ``map_path``, default: the map the scenario names); judge it against
    its folder's params.json when there is one. A file that fails the static or parameter
    checks is not played, unless ``force``: then it is played and judged all the same, and
    ``forced`` names the checks it fails."""
    from scenweave.judge import validate_xosc
    from scenweave.judge.findings import Finding, write_replay
    from scenweave.judge.replay import judge_collisions_only, verdict_of
    from scenweave.player import Playback, replay_file
    from scenweave.schemas.params import unchecked

    params_path = xosc.parent / PARAMS_NAME
    if params_path.is_file():
        params = unchecked(json.loads(params_path.read_text(encoding="utf-8")))
        result = validate_xosc(xosc, params, fix=False, replay=settings, map_path=map_path)
        # schemas keeps the playback duck-typed (it does not import the player)
        played = result.playback if isinstance(result.playback, Playback) else None
        playback, findings = played, [f for f in result.errors if f.severity == "error"]
        verdict = result.verdict
        forced = sorted({f.code for f in findings}) if force and playback is None else []
        if forced:
            playback, judged, verdict = _forced_replay(xosc, params, settings, map_path)
            findings += judged
    elif (map_path := map_path or _named_map(xosc)) is not None:
        playback = replay_file(xosc, map_path, settings)
        findings = judge_collisions_only(playback)
        verdict = verdict_of(findings, playback)
    else:
        playback, findings = None, [Finding("REPLAY_MAP", "its LogicFile names no known map; "
                                            "give one with --map")]
        verdict = None
    write_replay(xosc.parent, playback, verdict)
    if figures and playback is not None:
        from scenweave.presentation.replay_figures import draw_replay_figure

        draw_replay_figure(xosc.parent, map_path)
    return {"scenario": xosc.parent.name if xosc.name == XOSC_NAME else str(xosc),
            "played": playback is not None and not playback.engine_error,
            "passed": not findings, "codes": sorted({f.code for f in findings}),
            "errors": [f"{f.code}: {f.message}" for f in findings],
            **({"forced": forced} if params_path.is_file() and forced else {})}


def _forced_replay(xosc: Path, params: Params, settings, map_path: Path | None) -> tuple:
    """Play a file that failed the checks before the replay; the playback, the judge's
    findings (a REPLAY_MAP finding when no map is named) and its verdict."""
    from lxml import etree

    from scenweave.judge.findings import Finding
    from scenweave.judge.replay import replay_verdict
    from scenweave.judge.scenario_doc import ScenarioDoc
    from scenweave.player import replay_file

    doc = ScenarioDoc(etree.parse(str(xosc)), params.get("map"))
    map_path = map_path or doc.map_path
    if map_path is None:
        return None, [Finding("REPLAY_MAP", "its LogicFile names no known map; give one with "
                              "--map")], None
    playback = replay_file(xosc, map_path, settings)
    return (playback, *replay_verdict(playback, params, doc, map_path))


def _named_map(xosc: Path) -> Path | None:
    """The map the scenario's ``LogicFile`` names (None: no known map, or unreadable)."""
    from lxml import etree

    from scenweave.judge.scenario_doc import ScenarioDoc

    try:
        return ScenarioDoc(etree.parse(str(xosc))).map_path
    except (OSError, etree.XMLSyntaxError):
        return None

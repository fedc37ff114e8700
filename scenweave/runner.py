"""A batch: input -> params -> one scenario folder each -> ``summary.json``.

Scenarios of one manoeuvre class take spawn points round robin (thesis §5.2): the n-th
scenario of a class gets candidate ``n % top_n``, counted in input order so a resumed run
assigns the same spawns as an uninterrupted one.
"""

from __future__ import annotations

import importlib
import json
import multiprocessing
import time
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from scenweave.console import refused_records
from scenweave.in_situ_records import InSituWriter
from scenweave.inputs import InputSelection, LoadedInput, load_input
from scenweave.pipeline import PipelineSettings, process_scenario
from scenweave.progress import progress
from scenweave.run_folder import RunFolder, Started
from scenweave.schemas.params import Params
from scenweave.schemas.scenario_folder import (
    RECORDED_NAME,
    REPORT_FILE,
    RUN_FILE,
    STATUSES,
    SUMMARY_FILE,
)

if TYPE_CHECKING:
    from scenweave.spawn_db import SpawnMatcher
    from scenweave.spawn_db.registry import Matcher


@dataclass
class RunResult:
    """What a batch did: where it wrote, and its summary."""

    folder: RunFolder
    summary: dict
    skipped: int = 0
    input_issues: list = field(default_factory=list)
    #: finished scenarios never played before, played by this resumed run (scenweave.unplayed)
    played_later: int = 0

    @property
    def refused(self) -> int:
        """Records no scenario was made of: input errors (warnings are read records)."""
        return refused_records(self.input_issues)

    @property
    def problems(self) -> bool:
        """Something asked for was not delivered: a refused record, a failed scenario, or
        nothing at all (exit code 1)."""
        return (self.refused > 0 or self.summary["counts"].get("failed", 0) > 0
                or self.summary["total"] == 0)

    def line(self) -> str:
        """The one-line summary printed at the end of a run."""
        counts = self.summary["counts"]
        parts = ", ".join(f"{counts[s]} {s}" for s in STATUSES)
        later = f", {self.played_later} of them played now" if self.played_later else ""
        resumed = f" ({self.skipped} already done{later})" if self.skipped else ""
        refused = self.refused
        issues = f", {refused} refused" if refused else ""
        replay = self.summary.get("replay") or {}
        played = (f"; replay: {replay['passed']}/{replay['played']} played as recorded"
                  if replay.get("played") else "")
        variants = self.summary.get("variants") or {}
        varied = (f"; variants: {variants['kept']}/{variants['asked']} kept"
                  if variants.get("asked") else "")
        return (f"run {self.folder.run_id}: {self.summary['total']} scenarios: {parts}{resumed}"
                f"{issues}{played}{varied} -> {self.folder.root} "
                f"(open {self.folder.root / REPORT_FILE})")


def spawn_db_cache() -> Path:
    """Where spawn databases built for maps other than the shipped Town04 are cached."""
    from scenweave.agent.home import home

    return home() / "cache" / "spawn_db"


def default_matcher(map_name: str | None = None) -> SpawnMatcher:
    """The spawn matcher of ``map_name`` (a bundled town or an ``.xodr`` path; None: Town04).

    Its spawn database is the shipped one for Town04, otherwise built on first use and cached
    in ``spawn_db_cache()`` (``spawn_db.spawn_database``). Imported here so ``scenweave
    --help`` stays fast.
    """
    from scenweave.roads import resolve_map
    from scenweave.spawn_db import SpawnMatcher

    return SpawnMatcher.for_map(resolve_map(map_name), spawn_db_cache())


def run_batch(data: Path, out_root: Path, selection: InputSelection, settings: PipelineSettings,
              run_id: str | None = None, retry_failed: bool = False,
              matcher: Matcher | None = None, jobs: int = 1, announce: bool = False) -> RunResult:
    """Run every selected record of ``data`` into ``out_root/<run_id>/``; resume if it exists.

    ``jobs`` > 1 makes the scenarios in that many fresh processes (each gets the matcher once);
    this process commits each scenario folder. ``announce``: say the run's id and how to resume
    it as it starts (``scenweave run``; a bench or demo resumes by its own id, not this one).
    """
    loaded = load_input(Path(data), selection)
    matcher = matcher or default_matcher(settings.map)
    folder = RunFolder.open(out_root, run_id)
    if announce:
        folder.announce()
    if settings.agent is not None:  # the LLM calls are logged under the run
        settings = replace(settings, agent=replace(settings.agent, run_id=folder.run_id))
    with folder.started() as started:
        folder.write(RUN_FILE, run_description(data, loaded, selection, settings, folder))
        return _run_into(folder, started, loaded, settings, matcher, retry_failed, jobs)


def _run_into(folder: RunFolder, started: Started, loaded: LoadedInput,
              settings: PipelineSettings, matcher: Matcher, retry_failed: bool,
              jobs: int) -> RunResult:
    todo = []
    for index, params in round_robin(loaded.params):
        done = folder.trusted_outcome(params["scenario_id"])
        if not done or (retry_failed and done.get("status") == "failed"):
            todo.append((index, params))
    skipped = len(loaded.params) - len(todo)
    from scenweave.unplayed import play_unplayed

    # a resumed run with a player plays what a run without one delivered unplayed
    later = play_unplayed(folder, settings.replay) if settings.replay is not None else []
    stage = partial(_staging, folder, loaded.recorded)
    work = (_in_processes(todo, stage, settings, matcher, jobs) if jobs > 1 else
            _in_this_process(todo, stage, settings, matcher))
    in_situ = _in_situ_writer(loaded, settings)
    for params, staging, outcome in progress(work, desc="scenarios", total=len(todo)):
        if in_situ is not None and params["scenario_id"] in loaded.mined:
            outcome["in_situ"] = in_situ.write(loaded.mined[params["scenario_id"]], staging)
        folder.commit(params["scenario_id"], staging, outcome)
        started.committed += 1
    issues = [i.to_dict() for i in loaded.report.issues]
    summary = summarize(folder, issues)
    folder.write(SUMMARY_FILE, summary)
    from scenweave.presentation.report import write_run_report  # here: none before the first

    write_run_report(folder.root)
    return RunResult(folder, summary, skipped, issues, played_later=len(later))


def _in_situ_writer(loaded: LoadedInput, settings: PipelineSettings) -> InSituWriter | None:
    """Mined records get their event in situ beside the scenario (played when the run plays)."""
    return InSituWriter.for_run(play=settings.replay is not None) if loaded.mined else None


def _staging(folder: RunFolder, recorded: dict[str, dict], params: Mapping[str, Any]) -> Path:
    """The scenario's staging folder, holding what a mined record recorded (for its figure)."""
    staging = folder.staging(params["scenario_id"])
    series = recorded.get(params["scenario_id"])
    if series:
        (staging / RECORDED_NAME).write_text(json.dumps(series), encoding="utf-8")
    return staging


def make_scenario(params: Params, index: int, staging: Path, settings: PipelineSettings,
                  matcher: Matcher) -> dict:
    """``process_scenario``, then the replay figure the report will show (drawn here, in the
    worker that made the scenario, not serially at the end); its time is ``timings_s.figure``."""
    from scenweave.presentation.replay_figures import draw_replay_figure, is_reported

    outcome = process_scenario(params, index, staging, settings, matcher)
    if is_reported(outcome, index):
        started = time.perf_counter()
        draw_replay_figure(staging, status=outcome)
        outcome.setdefault("timings_s", {})["figure"] = round(time.perf_counter() - started, 4)
    return outcome


def _in_this_process(todo: list[tuple[int, Params]], stage: Callable[[Params], Path],
                     settings: PipelineSettings, matcher: Matcher
                     ) -> Iterator[tuple[Params, Path, dict]]:
    for index, params in todo:
        staging = stage(params)
        yield params, staging, make_scenario(params, index, staging, settings, matcher)


#: the batch's matcher, set before the workers fork: they inherit it instead of unpickling it
_worker_matcher: Matcher | None = None
#: what a scenario's making imports, loaded before the workers fork so each starts warm (the
#: scenario library's scenariogeneration and scipy alone are ~1.2 s of CPU per worker)
_PIPELINE_MODULES = ("scenweave.corpus", "scenweave.schemas", "scenweave.judge",
                     "scenweave.player", "scenweave.presentation.replay_figures",
                     "scenweave.scenario_lib.builder")


def _warm_before_fork(settings: PipelineSettings) -> None:
    """Do once, in this process, what every worker would do for its first scenario: import
    the pipeline, read the map (the matcher's lane graph), build its road graph (the
    replay's map cut) and sample its lanes' borders (the replay figure). Forked workers
    inherit all of it. A map that cannot be read is left to the scenarios, each of which
    fails for it as it did without this."""
    from scenweave import roads
    from scenweave.presentation.replay_panels import warm_lanes

    for module in _PIPELINE_MODULES:
        importlib.import_module(module)
    try:
        map_path = roads.resolve_map(settings.map).path
        roads.road_network(map_path)
        if settings.replay is not None:
            roads.road_graph(map_path)
            warm_lanes(map_path)
    except Exception:  # noqa: BLE001 - only a head start; the scenarios meet it themselves
        return


def _process_in_worker(params: Params, index: int, staging: Path,
                       settings: PipelineSettings) -> dict:
    if _worker_matcher is None:
        raise RuntimeError("_in_processes sets the batch's matcher before it forks the workers")
    return make_scenario(params, index, staging, settings, _worker_matcher)


def _in_processes(todo: list[tuple[int, Params]], stage: Callable[[Params], Path],
                  settings: PipelineSettings, matcher: Matcher,
                  jobs: int) -> Iterator[tuple[Params, Path, dict]]:
    """Each scenario made in one of ``jobs`` worker processes, yielded as it finishes.

    Workers are forked once this process has imported the pipeline, loaded the matcher and
    read the map (``_warm_before_fork``), so they start at once with all of it (spawned
    workers imported everything again and unpickled the matcher, ~4 s before the first
    scenario on two busy cores: a --jobs 2 run of 102 sample records was 1.2x a --jobs 1
    run). A forked worker starts its own player server (``player.engine`` forgets the
    parent's at a fork).
    """
    global _worker_matcher
    _warm_before_fork(settings)
    _worker_matcher = matcher
    context = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(jobs, mp_context=context) as pool:
        pending = {}
        for index, params in todo:
            staging = stage(params)
            future = pool.submit(_process_in_worker, params, index, staging, settings)
            pending[future] = (params, staging)
        for future in as_completed(pending):
            params, staging = pending[future]
            yield params, staging, future.result()


def round_robin(params_list: list[Params]) -> Iterator[tuple[int, Params]]:
    """Each params with its spawn index: its position among the records of its class."""
    per_class: Counter[str] = Counter()
    for params in params_list:
        yield per_class[params["maneuver_class"]], params
        per_class[params["maneuver_class"]] += 1


def summarize(folder: RunFolder, input_issues: list[dict]) -> dict:
    """Totals, per-class counts and the error taxonomy over every finished scenario."""
    from scenweave.unplayed import not_played_summary

    outcomes = folder.outcomes()
    counts = Counter(o["status"] for o in outcomes)
    by_class: dict[str, Counter] = {}
    for o in outcomes:
        by_class.setdefault(o["maneuver_class"], Counter())[o["status"]] += 1
    taxonomy = Counter(t for o in outcomes for t in o.get("error_taxonomy", []))
    return {
        "run_id": folder.run_id,
        "written_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "total": len(outcomes),
        "counts": {s: counts.get(s, 0) for s in STATUSES},
        "by_class": {code: {s: c.get(s, 0) for s in STATUSES}
                     for code, c in sorted(by_class.items())},
        "error_taxonomy": dict(sorted(taxonomy.items())),
        "tokens_in": sum(o.get("tokens_in", 0) for o in outcomes),
        "tokens_out": sum(o.get("tokens_out", 0) for o in outcomes),
        "attempts": sum(o.get("attempts", 0) for o in outcomes),
        "first_attempt_success": sum(bool(o.get("first_attempt_success")) for o in outcomes),
        "fallbacks": sum(bool(o.get("fallback")) for o in outcomes),
        "node_latency_s": node_latency(outcomes),
        "replay": {**replay_summary(outcomes), **not_played_summary(folder, outcomes)},
        "variants": variant_summary(outcomes),
        "input_issues": input_issues,
        "scenarios": outcomes,
    }


def variant_summary(outcomes: Sequence[Mapping[str, Any]]) -> dict:
    """The variants the LLM wrote (``run --vary``): asked, kept, the records with at least one
    kept, and what the kept ones changed."""
    variants = [v for o in outcomes for v in o.get("variants", [])]
    kept = [v for v in variants if v.get("kept")]
    return {"asked": len(variants), "kept": len(kept),
            "records_with_a_variant": sum(any(v.get("kept") for v in o.get("variants", []))
                                          for o in outcomes),
            "changed": dict(sorted(Counter(c for v in kept for c in v["changed"]).items()))}


def replay_summary(outcomes: Sequence[Mapping[str, Any]]) -> dict:
    """How many scenarios were played in esmini and replayed as recorded, in all and per class,
    and how often each REPLAY_* code came up."""
    played = [o for o in outcomes if o.get("replay")]
    by_class: dict[str, Counter] = {}
    for o in played:
        counts = by_class.setdefault(o["maneuver_class"], Counter())
        counts["played"] += 1
        counts["passed"] += bool(o["replay"].get("passed"))
    codes = Counter(c for o in played for c in o["replay"].get("codes", []))
    return {"played": len(played), "passed": sum(bool(o["replay"].get("passed")) for o in played),
            "by_class": {k: dict(v) for k, v in sorted(by_class.items())},
            "codes": dict(sorted(codes.items()))}


def node_latency(outcomes: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, float]]:
    """Per agent node: total seconds and mean seconds per scenario that visited it."""
    per_node: dict[str, list[float]] = {}
    for o in outcomes:
        for node, seconds in (o.get("node_latency_s") or {}).items():
            per_node.setdefault(node, []).append(seconds)
    return {node: {"total": round(sum(v), 4), "mean": round(sum(v) / len(v), 4),
                   "scenarios": len(v)} for node, v in per_node.items()}


def run_description(data: Path, loaded: LoadedInput, selection: InputSelection,
                    settings: PipelineSettings, folder: RunFolder) -> dict:
    """What ``run.json`` says: input, selection, mode and settings of the run, and why its
    scenarios are not played when they are not."""
    from scenweave.unplayed import RUN_KEY

    agent_settings = settings.agent
    return {
        "run_id": folder.run_id,
        "started_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "input": str(data), "input_kind": loaded.kind, "scenarios": len(loaded.params),
        "selection": described_selection(selection),
        "mode": "no-llm" if settings.no_llm else "agent",
        "map": settings.map or "Town04",
        "top_n": settings.top_n,
        "agent": agent_settings.to_dict() if hasattr(agent_settings, "to_dict") else None,
        RUN_KEY: settings.replay_not_run,
    }


def described_selection(selection: InputSelection) -> dict[str, Any]:
    """The selection as ``run.json`` keeps it (paths as text, tuples as lists)."""
    return json.loads(json.dumps({k: (str(v) if isinstance(v, Path) else v)
                                  for k, v in asdict(selection).items()}))


def latest_run_of(data: Path, out_root: Path, selection: InputSelection) -> str | None:
    """The id of the run in ``out_root`` last started on ``data`` with the same selection
    (``run --resume``), as each run's ``run.json`` describes it; None when there is none. A
    run killed before its first scenario has its ``run.json`` already, so it counts."""
    wanted = _inputs_of(str(data), described_selection(selection))
    found: list[tuple[str, float, str]] = []
    for path in Path(out_root).glob(f"*/{RUN_FILE}"):
        try:
            described = json.loads(path.read_text(encoding="utf-8"))
            seen = path.stat().st_mtime
        except (OSError, ValueError):
            continue  # a damaged run.json is no run of these inputs
        if isinstance(described, dict) and _inputs_of(
                described.get("input"), described.get("selection")) == wanted:
            found.append((str(described.get("started_at") or ""), seen, path.parent.name))
    return max(found)[2] if found else None


def _inputs_of(data: object, selection: object) -> tuple[str, str] | None:
    """What makes two runs runs of the same inputs: the input's absolute path (a relative
    one is taken from here, as a rerun of the same command does) and the selection."""
    if not isinstance(data, str) or not isinstance(selection, dict):
        return None
    return str(Path(data).resolve()), json.dumps(selection, sort_keys=True)

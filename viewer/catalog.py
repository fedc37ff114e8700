"""Which runs and scenarios the viewer shows, and what it says about each, read from the
folders ``scenweave run`` writes (``run.json``, ``summary.json``, one folder per scenario with
``status.json``, ``trace.jsonl``, ``replay.json``, ...).

A path given to ``scenweave view`` is a run folder, a folder of run folders (``runs/``), or
one scenario folder (a hand-edited copy played with ``scenweave replay --force``); each
scenario is named by ``<run>/<scenario folder>`` in the page's addresses.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenweave.errors import InputError
from scenweave.mining.criticality import criticality
from scenweave.schemas.scenario_folder import (
    IN_SITU_DIR,
    IN_SITU_REPORT_NAME,
    MINING_REPORT_PAGE,
    PARAMS_NAME,
    RECORDED_NAME,
    REPLAY_NAME,
    REPORT_FILE,
    RUN_FILE,
    SCENARIO_FILES,
    STATUS_NAME,
    SUMMARY_FILE,
    TRACE_NAME,
    VARIANT_NAME,
    VARIANTS_DIR,
    XOSC_NAME,
    read_json_lines,
    read_json_object,
)
from scenweave.viewer.in_situ import (
    IN_SITU_FILES,
    in_situ_of,
    in_situ_row,
    in_situ_scene,
    is_in_situ,
)
from scenweave.viewer.scene import scene

#: trace events that make or judge an attempt, in the order they run
ATTEMPT_NODES = ("generate", "repair", "fallback", "execute", "validate")
#: how many folder levels below a path given the runs are looked for
SEARCH_DEPTH = 3
#: a file the page shows inline is cut after this many characters
FILE_PREVIEW_CHARS = 200_000
#: the files the page lists: a scenario folder's, then an in-situ folder's own
SHOWN_FILES = (*SCENARIO_FILES, *(n for n in IN_SITU_FILES if n not in SCENARIO_FILES))


class NotFound(InputError, LookupError):
    """No run or scenario of that name among the folders the viewer was given."""


@dataclass
class Run:
    """One run folder (or one loose scenario folder, as a run of one)."""

    run_id: str
    root: Path
    scenario_dirs: dict[str, Path] = field(default_factory=dict)


def find_runs(paths: Iterable[Path]) -> dict[str, Run]:
    """Every run under ``paths``, by a unique name (the folder's, numbered when repeated)."""
    runs: dict[str, Run] = {}
    for path in paths:
        for root in _run_roots(Path(path)):
            name = root.name
            while name in runs:
                name += "+"
            runs[name] = Run(name, root, _scenario_dirs(root))
    return runs


def _run_roots(path: Path, depth: int = SEARCH_DEPTH) -> list[Path]:
    """``path`` if it is a run or a scenario folder, else the runs in its subfolders, looked
    for ``depth`` levels down (``runs/demo/runs/<run>`` as ``scenweave demo`` writes them)."""
    if _is_run(path) or _is_scenario(path):
        return [path]
    if depth == 0 or not path.is_dir():
        return []
    return [root for sub in sorted(p for p in path.iterdir()
                                   if p.is_dir() and not p.name.startswith("."))
            for root in _run_roots(sub, depth - 1)]


def _is_run(path: Path) -> bool:
    """A run folder, or the folder of in-situ scenarios ``scenweave mine --in-situ`` writes."""
    return (path / RUN_FILE).is_file() or (path / SUMMARY_FILE).is_file() \
        or (path / IN_SITU_REPORT_NAME).is_file()


def _is_scenario(path: Path) -> bool:
    return (path / XOSC_NAME).is_file() or (path / REPLAY_NAME).is_file() \
        or in_situ_of(path) is not None


def _scenario_dirs(root: Path) -> dict[str, Path]:
    if _is_scenario(root) and not _is_run(root):
        return {root.name: root}
    return {p.name: p for p in sorted(root.iterdir())
            if p.is_dir() and not p.name.startswith(".") and _is_scenario(p)}


# --- what the run list shows -----------------------------------------------------------------

def run_list(runs: dict[str, Run]) -> list[dict]:
    """Each run with its scenarios' rows (class, status, replay verdict, worst errors)."""
    return [run_row(run) for run in runs.values()]


def run_row(run: Run) -> dict:
    info, summary = read_json_object(run.root / RUN_FILE), read_json_object(run.root / SUMMARY_FILE)
    mined = _mined_criticality(run.root)
    row = {"run": run.run_id, "path": str(run.root), "mode": info.get("mode"),
           "map": info.get("map"), "started_at": info.get("started_at"),
           "counts": summary.get("counts"), "replay": _replay_counts(summary),
           "report": (run.root / REPORT_FILE).is_file(),
           "mining_report": _mining_report(info, run.root),
           "scenarios": [scenario_row(run, name, mined) for name in run.scenario_dirs]}
    return row


def _replay_counts(summary: dict) -> dict | None:
    replay = summary.get("replay")
    return {"played": replay.get("played"), "passed": replay.get("passed"),
            "not_played": replay.get("not_played") or 0,
            "not_played_because": replay.get("not_played_because")} \
        if isinstance(replay, dict) else None


def _mining_report(info: dict, root: Path) -> str | None:
    """The mining report of the records the run was made from, when ``scenweave mine`` made
    them (it lies beside the records)."""
    source = info.get("input")
    for folder in ([Path(source), root / source, root.parent.parent / source] if source else []):
        report = folder / MINING_REPORT_PAGE
        if report.is_file():
            return str(report.resolve())
    return None


def scenario_row(run: Run, name: str, mined: dict[str, dict] | None = None) -> dict:
    """What the list says of one scenario; ``mined``: the criticality of the records an
    in-situ batch was made from, by scenario id (``_mined_criticality``)."""
    folder = run.scenario_dirs[name]
    status, params = read_json_object(folder / STATUS_NAME), read_json_object(folder / PARAMS_NAME)
    replay = status.get("replay") if isinstance(status.get("replay"), dict) else None
    if replay is None and (folder / REPLAY_NAME).is_file():
        verdict = "played"
    elif replay is None:
        verdict = "not played"
    else:
        verdict = "passed" if replay.get("passed") else "failed"
    return {"id": name, "key": f"{run.run_id}/{name}",
            "maneuver_class": params.get("maneuver_class") or status.get("maneuver_class"),
            "domain": params.get("domain") or status.get("domain"),
            "status": status.get("status") or "unjudged",
            "attempts": status.get("attempts"), "verdict": verdict,
            "codes": (replay or {}).get("codes") or [],
            "worst": _worst_errors(folder),
            "variants": len(_variant_dirs(folder)),
            "watchable": (folder / REPLAY_NAME).is_file(),
            "in_situ": _in_situ_entry(folder, f"{run.run_id}/{name}"),
            "criticality": _criticality(folder) or (mined or {}).get(name)}


def _criticality(folder: Path) -> dict | None:
    """How critical the recorded event was (``mining.criticality``: least time to collision
    and headway, hardest 1 s of braking, peak lateral acceleration), measured on the series a
    mined record left beside its scenario (``recorded.json``); None for other scenarios."""
    series = read_json_object(folder / RECORDED_NAME) if (folder / RECORDED_NAME).is_file() \
        else {}
    return criticality(series) if series.get("t") else None


def _mined_criticality(root: Path) -> dict[str, dict]:
    """For the in-situ batch ``scenweave mine --in-situ`` writes (``OUT/in_situ/``, one folder
    per record, named by its scenario id): each record's criticality, read from the records
    beside it (``OUT/highway/*.json``, ``OUT/urban/*.json``); empty for any other run."""
    if not (root / IN_SITU_REPORT_NAME).is_file():
        return {}
    found: dict[str, dict] = {}
    for path in sorted(root.parent.glob("*/*.json")):
        if path.parent.name not in ("highway", "urban"):
            continue
        try:
            records = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue  # not a records file: nothing to say of it
        for record in records if isinstance(records, list) else []:
            numbers = record.get("criticality") if isinstance(record, dict) else None
            if isinstance(numbers, dict):
                found[str(record.get("scenario_id"))] = numbers
    return found


def _in_situ_entry(folder: Path, key: str) -> dict | None:
    """The scenario's in-situ scene (its key, vehicles, judge's numbers), if it has one or is
    one (``scenweave mine --in-situ`` writes in-situ folders alone)."""
    if is_in_situ(folder):
        return {"key": key, **in_situ_row(folder)}
    in_situ = in_situ_of(folder)
    return None if in_situ is None else {"key": f"{key}/{IN_SITU_DIR}", **in_situ_row(in_situ)}


def _worst_errors(folder: Path) -> list[dict]:
    """The largest series errors the judge measured against a mined record's series (max and
    RMS per quantity, ``replay.json``'s ``series_errors``), largest first; empty without."""
    errors = read_json_object(folder / REPLAY_NAME).get("series_errors") \
        if (folder / REPLAY_NAME).is_file() else None
    if not isinstance(errors, dict):
        return []
    rows = []
    for quantity, value in errors.items():
        if isinstance(value, dict) and isinstance(value.get("max"), int | float):
            rows.append({"quantity": quantity, "max": value["max"], "rms": value.get("rms")})
    return sorted(rows, key=lambda r: -abs(r["max"]))[:3]


# --- one scenario ----------------------------------------------------------------------------

def scenario_folder(runs: dict[str, Run], key: str) -> Path:
    """The folder of ``<run>/<scenario>``, of ``<run>/<scenario>/variants/vNN`` or of
    ``<run>/<scenario>/in_situ``."""
    run_id, _, rest = key.partition("/")
    if rest.endswith(f"/{IN_SITU_DIR}"):
        owner = scenario_folder(runs, f"{run_id}/{rest.removesuffix('/' + IN_SITU_DIR)}")
        if in_situ_of(owner) is None:
            raise NotFound(f"{key!r}: the scenario has no in-situ scene")
        return owner / IN_SITU_DIR
    name, _, variant = rest.partition("/variants/")
    run = runs.get(run_id)
    if run is None or name not in run.scenario_dirs:
        raise NotFound(f"no scenario {key!r} in the runs shown")
    folder = run.scenario_dirs[name]
    if variant:
        folder = folder / VARIANTS_DIR / variant
        if not folder.is_dir() or "/" in variant or variant.startswith("."):
            raise NotFound(f"no variant {variant!r} of {name}")
    return folder


def scenario_detail(runs: dict[str, Run], key: str) -> dict:
    """Everything the scenario's page shows: the scene to animate and chart, the status, the
    agent's attempts, the variants and the files."""
    folder = scenario_folder(runs, key)
    if is_in_situ(folder) and not (folder / PARAMS_NAME).is_file():
        return {"key": key, "scene": in_situ_scene(folder), "status": {}, "params": {},
                "attempts": [], "variants": [], "files": files(folder), "variant": None}
    return {"key": key, "scene": scene(folder), "status": read_json_object(folder / STATUS_NAME),
            "params": read_json_object(folder / PARAMS_NAME), "attempts": attempts(folder),
            "variants": variants(folder, key), "files": files(folder),
            "in_situ": _in_situ_entry(folder, key),
            "variant": read_json_object(folder / VARIANT_NAME) or None}


def attempts(folder: Path) -> list[dict]:
    """The agent's attempts from ``trace.jsonl``: each made (generate, repair or fallback)
    with what it was given and answered, then run in the sandbox and validated."""
    found: list[dict] = []
    for event in _events(folder / TRACE_NAME):
        node = event.get("node")
        if node in ("generate", "repair", "fallback") or (node == "validate" and not found):
            found.append({"number": event.get("number") or len(found) + 1,
                          "made_by": node if node != "validate" else "reference script",
                          "make": event if node != "validate" else {}, "execute": None,
                          "validate": None})
        if node in ("execute", "validate") and found:
            found[-1][node] = event
    return found


def _events(path: Path) -> list[dict]:
    """The trace's events; a line that is no event is left out."""
    return [event for event in read_json_lines(path) if event is not None]


def _variant_dirs(folder: Path) -> list[Path]:
    root = folder / VARIANTS_DIR
    return sorted(p for p in root.iterdir() if p.is_dir()) if root.is_dir() else []


def variants(folder: Path, key: str) -> list[dict]:
    """The record's variants: what each changed, whether it was kept, and its key."""
    return [{"name": path.name, "key": f"{key}/{VARIANTS_DIR}/{path.name}",
             "variant": read_json_object(path / VARIANT_NAME),
             "watchable": (path / REPLAY_NAME).is_file()}
            for path in _variant_dirs(folder)]


def files(folder: Path) -> list[dict]:
    return [{"name": name, "bytes": (folder / name).stat().st_size}
            for name in SHOWN_FILES if (folder / name).is_file()]


def file_text(runs: dict[str, Run], key: str, name: str) -> str:
    """A listed file of the scenario, as text (cut after ``FILE_PREVIEW_CHARS``)."""
    if name not in SHOWN_FILES:
        raise NotFound(f"{name!r} is not a file the viewer shows")
    path = scenario_folder(runs, key) / name
    if not path.is_file():
        raise NotFound(f"{key} has no {name}")
    text = path.read_text(encoding="utf-8", errors="replace")
    return text[:FILE_PREVIEW_CHARS]


def as_json(data: Any) -> str:
    """Compact JSON a browser parses: a non-finite number (NaN, inf) becomes null."""
    return json.dumps(_finite(data), separators=(",", ":"), default=str, allow_nan=False)


def _finite(data: Any) -> Any:
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [_finite(v) for v in data]
    return data

"""The scenario folder and the run folder: the contract between the pipeline, the agent, the
queue, the reports and the viewer.

Every file name of a run (``runs/<run_id>/``) and of a scenario folder in it is declared here
and nowhere else; so are the outcome a scenario ends with (``status.json``, :class:`Outcome`)
and the verdict the judge writes on its replay (``verdict.json``, :class:`ReplayVerdict`:
what it expected beside what it observed, each finding with its time). Readers of a folder
read it with :func:`read_json_object` and :func:`read_json_lines`, which take a missing or
damaged file for an empty one: a folder is shown as far as it can be, never refused.

A scenario folder::

    scenario.xosc  scenario.py  params.json  status.json  trace.jsonl  checkpoints.sqlite
    replay.json  verdict.json  replay.svg  recorded.json  attempts/<n>/...
    variants/<id>/{variant.json, reference.xosc, scenario.xosc, ...}
    in_situ/{scenario.xosc, road.xodr, in_situ.json, replay.json, judge.json,
             hero_reference.csv}

This module imports nothing of ScenWeave, so every stage can import it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal, NotRequired, TypedDict, cast

# --- the run folder --------------------------------------------------------------------------

#: what the run was asked (input, settings, map, queue): written when it starts
RUN_FILE = "run.json"
#: every scenario's outcome and the counts, rewritten as scenarios finish
SUMMARY_FILE = "summary.json"
#: the run's static report page
REPORT_FILE = "report.html"
#: scenario folders in the making, each moved into place with one rename
STAGING_DIR = ".staging"

# --- a scenario folder -----------------------------------------------------------------------

#: the delivered OpenSCENARIO 1.0 file
XOSC_NAME = "scenario.xosc"
#: the final script that wrote it (the reference or the LLM's)
CODE_NAME = "scenario.py"
#: the params the scenario was made from, spawn placed
PARAMS_NAME = "params.json"
#: the outcome (:class:`Outcome`), written last: a folder without it is not finished
STATUS_NAME = "status.json"
#: the readable event log, one JSON object per line
TRACE_NAME = "trace.jsonl"
#: the agent's LangGraph checkpoints of the scenario's thread
CHECKPOINTS_NAME = "checkpoints.sqlite"
#: the agent's attempts, one folder each (``attempts/<n>/scenario.xosc``)
ATTEMPTS_DIR = "attempts"
#: what esmini did when playing the scenario (``player.Playback``)
REPLAY_NAME = "replay.json"
#: the judge's verdict on the replay (:class:`ReplayVerdict`)
VERDICT_NAME = "verdict.json"
#: the replay figure (``scenweave.presentation.replay_figures``)
FIGURE_NAME = "replay.svg"
#: a mined record's recorded series, beside the scenario it became (``scenweave mine``)
RECORDED_NAME = "recorded.json"
#: the variants the LLM wrote of the scenario, one folder each
VARIANTS_DIR = "variants"
#: what a variant was asked and what it changed
VARIANT_NAME = "variant.json"
#: the parametric reference of a variant's asked params, for comparison
REFERENCE_NAME = "reference.xosc"

#: the files of a scenario folder a reader lists and links, in this order
SCENARIO_FILES = (XOSC_NAME, CODE_NAME, PARAMS_NAME, STATUS_NAME, TRACE_NAME, REPLAY_NAME,
                  VERDICT_NAME, FIGURE_NAME, RECORDED_NAME, REFERENCE_NAME, VARIANT_NAME)

# --- the event in situ (a mined event on its recorded road) ----------------------------------

#: the in-situ scenario's folder inside the scenario folder; it holds its own
#: ``scenario.xosc`` (XOSC_NAME), ``replay.json`` (REPLAY_NAME), verdict (VERDICT_NAME) and:
IN_SITU_DIR = "in_situ"
#: the recorded road as OpenDRIVE, which the in-situ scenario's LogicFile names
ROAD_NAME = "road.xodr"
#: what was chosen to play: file, ego, tracks, window
IN_SITU_CHOICE_NAME = "in_situ.json"
#: the ego's recorded trajectory, for a driving stack in the ego's seat
HERO_REFERENCE_NAME = "hero_reference.csv"
#: the in-situ judge's verdict (``judge.in_situ.InSituVerdict``: every recorded vehicle and
#: sample against the replay), where a scenario's replay has VERDICT_NAME
IN_SITU_VERDICT_NAME = "judge.json"
#: beside the in-situ folders ``scenweave mine --in-situ`` writes: what was written, refused
IN_SITU_REPORT_NAME = "in_situ_report.json"

# --- beside the records a run is made from (``scenweave ingest``, ``scenweave mine``) --------

#: what ingest read and refused
INGEST_REPORT_NAME = "ingest_report.json"
#: what mining found and skipped, and its page (``scenweave.presentation.mining_report``)
MINING_REPORT_NAME = "mining_report.json"
MINING_REPORT_PAGE = "mining_report.html"

# --- status.json -----------------------------------------------------------------------------

Status = Literal["ok", "repaired", "fallback", "failed"]
#: the outcomes, in the order reports count them
STATUSES: tuple[Status, ...] = ("ok", "repaired", "fallback", "failed")


class ReplaySummary(TypedDict):
    """What the replay of a validated scenario showed, as ``status.json`` keeps it."""

    played: bool
    passed: bool
    #: the REPLAY_* codes found, sorted
    codes: list[str]
    timings_s: dict[str, float]
    #: per "<entity> <quantity>", how far the replay is from a record's series
    series_errors: NotRequired[dict[str, dict[str, float]]]


class Outcome(TypedDict):
    """``status.json``: how one scenario ended. The keys every outcome has; the stages add
    theirs (timings, retrieval, variants, the worker, what stayed behind)."""

    scenario_id: str
    maneuver_class: str
    domain: str
    status: Status
    attempts: int
    first_attempt_success: bool
    fallback: bool
    spawn_id: int | str | None
    tokens_in: int
    tokens_out: int
    error_taxonomy: list[str]
    error: str | None
    validation: dict[str, Any] | None
    replay: ReplaySummary | None
    timings_s: NotRequired[dict[str, float]]
    retrieval: NotRequired[str]
    variants: NotRequired[list[dict[str, Any]]]
    worker: NotRequired[str]
    submission: NotRequired[str | None]
    artefacts_left_behind: NotRequired[list[dict[str, Any]]]


# --- verdict.json ----------------------------------------------------------------------------

class VerdictFinding(TypedDict):
    """One REPLAY_* finding: its code, its message and when it happened (s; None: no time)."""

    code: str
    message: str
    t: float | None


class VerdictMark(TypedDict):
    """One value the judge expected of the replay: whose, what, when (s), the record's value,
    what the replay showed (None: not compared, e.g. past the scenario's end) and how far
    the two may differ."""

    entity: str
    what: str
    t: float
    expected: float
    observed: float | None
    tol: float


class Tolerances(TypedDict):
    """How far the replay may differ from the record: a speed (m/s), a gap (m), a recorded
    series' speed and gap at every sample, a lane change's timing (s)."""

    speed_ms: float
    gap_m: float
    series_speed_ms: float
    series_gap_m: float
    lane_change_s: float


class ReplayVerdict(TypedDict):
    """``verdict.json``: the judge's verdict on one replay, written beside ``replay.json``."""

    passed: bool
    #: the REPLAY_* codes found, sorted
    codes: list[str]
    findings: list[VerdictFinding]
    #: start speeds and the targets of the scripted speed changes
    speed_marks: list[VerdictMark]
    #: the recorded gaps to the ego along the lane (highway)
    gap_marks: list[VerdictMark]
    tolerances: Tolerances
    #: per "<entity> <quantity>", how far the replay is from a record's series (max, RMS)
    series_errors: dict[str, dict[str, float]]


# --- reading a folder ------------------------------------------------------------------------

def read_json_object(path: Path) -> dict[str, Any]:
    """The JSON object in ``path``; ``{}`` when the file is missing, unreadable, not JSON or
    not an object (a folder is shown as far as it can be)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def read_json_lines(path: Path) -> list[dict[str, Any] | None]:
    """The objects of a JSON-lines file in order, None for each line that is not one (its
    place kept, so a reader can say which line it was); blank lines skipped; ``[]`` when the
    file cannot be read."""
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, ValueError):
        return []
    found: list[dict[str, Any] | None] = []
    for line in lines:
        if line.strip():
            try:
                event = json.loads(line)
            except ValueError:
                event = None
            found.append(event if isinstance(event, dict) else None)
    return found


def read_outcome(folder: Path) -> Outcome | None:
    """A scenario folder's ``status.json``, or None while it has none (or a damaged one)."""
    data = read_json_object(Path(folder) / STATUS_NAME)
    return cast(Outcome, data) if data.get("scenario_id") is not None else None


def read_verdict(folder: Path) -> ReplayVerdict | None:
    """A folder's ``verdict.json``, or None when its replay was not judged (or before the
    judge wrote verdicts)."""
    data = read_json_object(Path(folder) / VERDICT_NAME)
    return cast(ReplayVerdict, data) if isinstance(data.get("findings"), list) else None


#: the files a delivered (not failed) scenario's folder holds whatever else it did: a resume
#: trusts ``status.json`` only when they are there and readable (a replay cut off, with no
#: ``replay.json``, is played again later rather than made again)
DELIVERED_FILES = (XOSC_NAME, PARAMS_NAME)


def folder_damage(folder: Path, outcome: Outcome) -> str | None:
    """Why the finished scenario in ``folder`` cannot be trusted as ``outcome`` says (a file
    it names missing or unreadable), or None when it is whole. A failed outcome names none."""
    if outcome.get("status") == "failed":
        return None
    for name in DELIVERED_FILES:
        why = _unreadable(Path(folder) / name)
        if why:
            return f"its status.json says {outcome.get('status')} but {name} {why}"
    return None


def _unreadable(path: Path) -> str | None:
    """Why ``path`` cannot be read as its kind (JSON object, XML), or None."""
    import xml.etree.ElementTree as ElementTree

    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return "is missing"
    except (OSError, ValueError) as err:
        return f"cannot be read ({err})"
    try:
        if path.suffix == ".json" and not isinstance(json.loads(text), dict):
            return "holds no JSON object"
        if path.suffix == ".xosc":
            ElementTree.fromstring(text)
    except (ValueError, ElementTree.ParseError) as err:
        return f"is damaged ({err})"
    return None

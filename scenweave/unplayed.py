"""Scenarios delivered but never played in esmini: say so, and play them once a player is here.

A scenario is validated whether or not esmini is installed; without the player its replay (the
check that it plays back what was recorded) is not run, and an ``ok`` then means less than it
says. So the run records why it did not play (``run.json``: ``replay_not_run``), its summary
counts the scenarios not played (``summary.json``: ``replay.not_played`` and
``replay.not_played_because``), every command that ends a run prints one line saying so
(:func:`not_played_line`), and a later run of the same ``--run-id`` with a player, or
``scenweave replay RUN_DIR``, plays exactly those scenarios (:func:`play_unplayed`): each is
copied to staging, played, judged against its ``params.json`` and committed whole again, so
a scenario that does not replay as recorded becomes ``failed`` (taxonomy ``replay``) as in a
run that had the player from the start.

A scenario counts as not played when it was delivered (ok, repaired, fallback) and either its
``status.json`` has no replay, or it has one but the folder lacks ``replay.json`` (the replay
was cut off before its playback was written).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from scenweave.run_folder import RunFolder
from scenweave.schemas.scenario_folder import (
    PARAMS_NAME,
    REPLAY_NAME,
    RUN_FILE,
    XOSC_NAME,
    read_json_object,
)

#: ``run.json``: why the run's scenarios are not played (absent or None: they are)
RUN_KEY = "replay_not_run"
#: why, when the user turned the replay off
TURNED_OFF = "--no-replay"
#: the statuses of a delivered scenario (a failed one is not played: there is nothing to play)
DELIVERED = ("ok", "repaired", "fallback")
#: what the user does about a missing player
DOCTOR_HINT = "`scenweave doctor` says how to get the player (esmini)"


@dataclass(frozen=True)
class ReplayPlan:
    """Whether a run plays its scenarios: the settings (None: it does not) and why not."""

    settings: Any = None  # player.ReplaySettings
    not_run_because: str | None = None


def replay_plan(wanted: bool | None) -> ReplayPlan:
    """The replay a command runs: asked for (``--replay``: a missing esmini raises
    ``PlayerUnavailable``), turned off (``--no-replay``), or by default on when esmini is
    found, else off with the player's own reason."""
    if wanted is False:
        return ReplayPlan(None, TURNED_OFF)
    from scenweave.player import PlayerUnavailable, ReplaySettings, find_esmini

    try:
        find_esmini()
    except PlayerUnavailable as err:
        if wanted:
            raise
        return ReplayPlan(None, f"no player: {err}")
    return ReplayPlan(ReplaySettings())


def is_unplayed(outcome: Mapping[str, Any], scenario_dir: Path | None = None) -> bool:
    """A delivered scenario never played, or whose replay was cut off before its playback
    was written (``scenario_dir`` given: its ``replay.json`` is missing)."""
    if outcome.get("status") not in DELIVERED:
        return False
    if not isinstance(outcome.get("replay"), dict):
        return True
    return scenario_dir is not None and not (Path(scenario_dir) / REPLAY_NAME).is_file()


def unplayed_ids(folder: RunFolder) -> list[str]:
    """The run's scenarios :func:`is_unplayed`, by scenario id."""
    return [o["scenario_id"] for o in folder.outcomes()
            if is_unplayed(o, folder.scenario_dir(o["scenario_id"]))]


def not_played_summary(folder: RunFolder, outcomes: Iterable[Mapping[str, Any]]) -> dict:
    """``summary.json``'s ``replay.not_played`` (how many) and ``not_played_because`` (the
    run's reason, from ``run.json``; None when every delivered scenario was played)."""
    count = sum(is_unplayed(o, folder.scenario_dir(o["scenario_id"])) for o in outcomes)
    because = read_json_object(folder.root / RUN_FILE).get(RUN_KEY) if count else None
    if count and not because:
        because = "its replay was not run or did not finish"
    return {"not_played": count, "not_played_because": because}


def not_played_line(summary: Mapping[str, Any], run_dir: Path) -> str | None:
    """One line for the terminal when scenarios of the run were not played although the user
    did not turn the replay off: how many, why, and what to do; None when every delivered
    scenario was played or ``--no-replay`` was asked (``summary.json`` still counts them)."""
    replay = summary.get("replay") or {}
    count = replay.get("not_played") or 0
    because = short_reason(replay.get("not_played_because") or "unknown")
    if not count or because == TURNED_OFF:
        return None
    delivered = sum((summary.get("counts") or {}).get(s, 0) for s in DELIVERED)
    return (f"replay: NOT RUN for {count} of {delivered} delivered scenarios ({because}): they "
            f"are validated but not checked against the record; {DOCTOR_HINT}; then "
            f"`scenweave replay {run_dir}` plays them")


def short_reason(because: str) -> str:
    """The reason without the list of places searched (``esmini not found (...); set ...``
    becomes ``no player: esmini not found``); the whole is in ``summary.json``."""
    return because.split(" (", 1)[0].split(";", 1)[0]


def play_unplayed(folder: RunFolder, settings: Any, map_path: Path | None = None,
                  on_done: Callable[[str, dict], None] | None = None) -> list[dict]:
    """Play every scenario of the run :func:`is_unplayed` (``settings``: player.ReplaySettings;
    ``map_path``: a map to play on instead of the scenario's own) and commit each again with
    its replay; return the new outcomes. ``on_done(scenario_id, outcome)`` follows each."""
    done = []
    for scenario_id in unplayed_ids(folder):
        staging = folder.staging(scenario_id)
        shutil.copytree(folder.scenario_dir(scenario_id), staging, symlinks=True,
                        dirs_exist_ok=True)
        outcome = play_staged(staging, folder.outcome(scenario_id) or {}, settings, map_path)
        folder.commit(scenario_id, staging, outcome)
        done.append(outcome)
        if on_done is not None:
            on_done(scenario_id, outcome)
    return done


def play_staged(staging: Path, outcome: Mapping[str, Any], settings: Any,
                map_path: Path | None = None) -> dict:
    """Play the delivered ``scenario.xosc`` in ``staging`` (a copy of its folder), judge it
    against its ``params.json``, write ``replay.json`` and ``verdict.json`` there; the
    outcome with the replay, ``failed`` when the scenario does not replay as recorded."""
    import time

    from scenweave.judge import failure_category, validate_xosc
    from scenweave.schemas.params import unchecked

    started = time.perf_counter()
    params = unchecked(json.loads((staging / PARAMS_NAME).read_text(encoding="utf-8")))
    result = validate_xosc(staging / XOSC_NAME, params, fix=False, replay=settings,
                           map_path=map_path)
    result.write_replay(staging)
    errors = [f.to_dict() for f in result.errors if f.severity == "error"]
    new = {**outcome, "replay": result.replay,
           "replayed_later_at": datetime.now(UTC).isoformat(timespec="seconds")}
    new["timings_s"] = {**(outcome.get("timings_s") or {}),
                        "replay_later": round(time.perf_counter() - started, 4)}
    if not result.valid:
        new.update(status="failed", error_taxonomy=[failure_category(errors)],
                   error="; ".join(e["code"] for e in errors[:5]),
                   validation={**(outcome.get("validation") or {}), "valid": False,
                               "errors": errors[:20]})
    return new


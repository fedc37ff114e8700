"""Variants of a delivered scenario (``scenweave run --vary N``): the LLM rewrites the final
script changing one thing the record does not fix (weather and time of day, a vehicle model,
background traffic, the lane; ``schemas.variation.ASPECTS`` in turn), and a variant is kept
only when

- it runs in the sandbox, given what the delivered script was given;
- it changes what it may and nothing the record fixes (``schemas.variation.compare``);
- it is valid and still plays the recorded manoeuvre (``validate_xosc`` with the replay,
  against the record's params with the variant's own weather, and for the lane the params
  the spawn stage placed one lane over);
- no kept variant of the record is the same file.

A lane variant asks the spawn stage first (``lane_over``: ``SpawnMatcher.lane_over``, the
record placed so its gaps hold along the neighbouring lanes); the LLM is given the values that
moved, and the reference script played there (``lane_over.xosc``) is what the variant must
start as. Where the map has no room one lane over, the variant is not asked for
(``VARY_NO_LANE``).

Each variant gets ``variants/vNN/`` in the scenario folder: its script, its scenario when it
ran, and ``variant.json`` (what it changed, kept or why not).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenweave.agent.code import extract_python_code
from scenweave.agent.prompts import variant_prompt
from scenweave.agent.run import shared_llm, shared_sandbox
from scenweave.agent.settings import AgentSettings
from scenweave.agent.trace import CODE_NAME, XOSC_NAME, Trace
from scenweave.corpus.worked_example import provenance
from scenweave.player import REPLAY_NAME
from scenweave.schemas.variation import ASPECTS, compare
from scenweave.spawn_db.errors import SpawnDbError

VARIANTS_DIR = "variants"
VARIANT_FILE = "variant.json"
#: the reference scenario one lane over, which a lane variant must start as
LANE_OVER_NAME = "lane_over.xosc"
#: what ``variant.json`` says of where a lane variant put the record
PLACEMENT_KEYS = ("spawn_id", "ego_road_id", "ego_lane_id", "ego_s")


def make_variants(params: dict, out_dir: Path, settings: AgentSettings, count: int,
                  replay: Any, parametric: bool, trace: Trace,
                  lane_over: Callable[[int], dict] | None = None) -> list[dict]:
    """``count`` variants of the scenario in ``out_dir``; what each changed, kept or not.

    ``parametric``: the delivered script is the reference (a fallback), which reads params.
    ``lane_over(n)``: the params placed one lane over for the n-th lane variant (raises
    ``SpawnDbError`` where the map has no room; None: no lane variants).
    """
    code = (out_dir / CODE_NAME).read_text(encoding="utf-8")
    given = params if parametric else provenance(params)
    seen = {_digest(out_dir / XOSC_NAME)}
    found = []
    for number in range(1, count + 1):
        aspect = ASPECTS[(number - 1) % len(ASPECTS)]
        folder = out_dir / VARIANTS_DIR / f"v{number:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        try:
            target = _target(params, aspect, lane_over, folder, (number - 1) // len(ASPECTS))
        except SpawnDbError as err:
            variant = {"id": folder.name, "aspect": aspect, "kept": False, "changed": [],
                       "errors": [f"VARY_NO_LANE: {err}"]}
        else:
            variant = _variant(params, target, code, aspect, given, folder, out_dir, settings,
                               replay, seen)
        (folder / VARIANT_FILE).write_text(json.dumps(variant, indent=1), encoding="utf-8")
        trace.event("variant", **variant)
        found.append(variant)
    return found


@dataclass(frozen=True)
class _Target:
    """Where a variant may play the record: as placed, or (the lane aspect) one lane over,
    with the reference scenario there."""

    #: the record's params the variant is judged against when it moved lanes
    placed: dict
    #: the reference played at ``placed`` (None: the variant stays where the record is)
    moved: Path | None = None


def _target(params: dict, aspect: str, lane_over: Callable[[int], dict] | None,
            folder: Path, round_number: int) -> _Target:
    if aspect != "lane":
        return _Target(params)
    if lane_over is None:
        raise SpawnDbError("this run places no scenario one lane over")
    from scenweave import corpus

    placed = lane_over(round_number)
    moved = folder / LANE_OVER_NAME
    corpus.generate(placed, moved)
    return _Target(placed, moved)


def _variant(params: dict, target: _Target, code: str, aspect: str, given: dict, folder: Path,
             out_dir: Path, settings: AgentSettings, replay: Any, seen: set[str]) -> dict:
    found: dict[str, Any] = {"id": folder.name, "aspect": aspect, "kept": False,
                             "changed": [], "errors": []}
    if target.moved is not None:
        found["placed"] = {key: target.placed.get(key) for key in PLACEMENT_KEYS}
    prompt = variant_prompt(params, code, aspect, target.placed)
    written = extract_python_code(shared_llm(settings).complete(prompt).text).code
    (folder / CODE_NAME).write_text(written, encoding="utf-8")
    if not written:
        return found | {"errors": ["the reply held no Python code"]}
    result = shared_sandbox(settings).run(written, given, folder)
    scenario = folder / XOSC_NAME
    if not result.ok or not scenario.is_file():
        return found | {"errors": [f"{result.error_type or 'NoOutput'}: "
                                   f"{result.error_message or 'no scenario written'}"]}
    variation = compare(out_dir / XOSC_NAME, scenario, target.moved)
    found["changed"] = variation.changed
    errors = [f"{f.code}: {f.message}" for f in variation.violations]
    if not variation.changed:
        errors.append("VARY_NOTHING: the variant is the faithful scenario")
    errors += _replay_errors(scenario, target.placed if variation.moved else params, replay)
    digest = _digest(scenario)
    if not errors and digest in seen:
        errors.append("VARY_DUPLICATE: an earlier variant is the same file")
    seen.add(digest)
    return found | {"kept": not errors, "errors": errors}


def _replay_errors(scenario: Path, params: dict, replay: Any) -> list[str]:
    """Valid and playing the record, against its params with the variant's own weather (the
    one value the record fixes that a variant may change)."""
    from lxml import etree

    from scenweave.schemas import validate_xosc
    from scenweave.schemas.scenario_doc import ScenarioDoc

    weather = ScenarioDoc(etree.parse(str(scenario))).weather_name
    result = validate_xosc(scenario, {**params, "weather_key": weather or params["weather_key"]},
                           replay=replay)
    if result.playback is not None:  # what it played, beside it (replay.json)
        result.playback.write(scenario.with_name(REPLAY_NAME))
    return [f"{f.code}: {f.message}" for f in result.errors if f.severity == "error"]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()

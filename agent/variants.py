"""Variants of a delivered scenario (``scenweave run --vary N``): the LLM rewrites the final
script changing one thing the record does not fix (weather and time of day, a vehicle model,
background traffic, the lane; ``judge.variation.ASPECTS`` in turn), and a variant is kept
only when

- it runs in the sandbox, given only the record's provenance (``scenario_id``): every value
  is written into the script;
- it changes what it may and nothing the record fixes (``judge.variation.compare``);
- it is valid and still plays the recorded manoeuvre (``validate_xosc`` with the replay,
  against the record's params as the variant was asked to change them, with its own weather);
- no kept variant of the record is the same file.

The weather is the LLM's to choose. A vehicle model, background traffic and the lane touch
values the record's other values depend on, or must keep clear of it, so ScenWeave works out
what the record becomes first (``asked_params``) and hands the LLM the values that change:

- another model for one vehicle keeps the free space between the bumpers the record fixes
  (``ingest.extract.with_vehicle_type``), so the reference-point gaps move, and the scenario
  is placed anew from the same spawn point (``SpawnMatcher.place_at``);
- background traffic: one vehicle in a same-direction lane the record neither starts in nor
  moves into, a little ahead of the ego at its speed (``SpawnMatcher.background``; the
  reference scripts play it through ``scenario_lib.builder.make_scenario``);
- the lane: the spawn stage places the record one lane over (``SpawnMatcher.lane_over``), its
  gaps measured along the new lanes.

The reference script played with those values (``reference.xosc`` beside the variant, its
params in ``params.json``) is what such a variant must match in everything the record fixes.
Where the record has no room one lane over (``VARY_NO_LANE``), no vehicle but the ego
(``VARY_NO_VEHICLE``), or no room for the other model or a free lane (``VARY_NO_ROOM``), no
LLM call is spent.

With the ``patch`` strategy the LLM answers with JSON line edits of the delivered script, held
to the same grammar as its repairs, instead of the whole script.

Each variant gets ``variants/vNN/`` in the scenario folder: its script, its scenario when it
ran, and ``variant.json`` (what it changed, what it was asked to change, kept or why not).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

from scenweave import corpus
from scenweave.agent.code import PatchError, extract_python_code
from scenweave.agent.edits import apply_edits
from scenweave.agent.prompts import variant_prompt
from scenweave.agent.run import shared_llm, shared_sandbox
from scenweave.agent.settings import AgentSettings
from scenweave.agent.trace import CODE_NAME, PARAMS_NAME, XOSC_NAME, Trace
from scenweave.corpus.worked_example import provenance, worked_example
from scenweave.errors import ScenarioError
from scenweave.ingest.extract import with_vehicle_type
from scenweave.judge.variation import ASPECTS, compare
from scenweave.player import REPLAY_NAME, Playback
from scenweave.scenario_lib.vehicles import known_type
from scenweave.schemas.params import Params
from scenweave.spawn_db.errors import SpawnDbError

VARIANTS_DIR = "variants"
VARIANT_FILE = "variant.json"
#: the reference script played with the values a variant was asked to change
REFERENCE_NAME = "reference.xosc"
#: where ``variant.json`` says a lane variant put the record
PLACEMENT_KEYS = ("spawn_id", "ego_road_id", "ego_lane_id", "ego_s")
#: the repair strategy whose variants are JSON line edits of the script (held to a grammar)
EDIT_STRATEGY = "patch"
#: the vehicle models a vehicles variant gives a recorded actor, in turn
VEHICLE_TYPES = ("car", "van", "truck")


class NotAsked(ScenarioError):
    """A variant of this aspect cannot be made of the record; ``code`` says why."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code = code


def make_variants(params: dict, out_dir: Path, settings: AgentSettings, count: int,
                  replay: Any, parametric: bool, trace: Trace, matcher: Any) -> list[dict]:
    """``count`` variants of the scenario in ``out_dir``; what each changed, kept or not.

    ``parametric``: the delivered script is the reference (a fallback), which reads params;
    the variants then start from the record's worked example (its values written in, the
    same scenario), so that each is a change of values, as when the LLM delivered.
    ``matcher``: the spawn stage that placed ``params`` (``SpawnMatcher``).
    """
    code = (worked_example(corpus.retrieve(params).script_path, params) if parametric
            else (out_dir / CODE_NAME).read_text(encoding="utf-8"))
    given = provenance(params)
    seen = {_digest(out_dir / XOSC_NAME)}
    found = []
    for number in range(1, count + 1):
        aspect = ASPECTS[(number - 1) % len(ASPECTS)]
        folder = out_dir / VARIANTS_DIR / f"v{number:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        variant: dict[str, Any] = {"id": folder.name, "aspect": aspect, "kept": False,
                                   "changed": [], "asked": {}, "errors": []}
        try:
            asked = asked_params(params, aspect, matcher, (number - 1) // len(ASPECTS))
        except NotAsked as err:
            variant["errors"] = [f"{err.code}: {err}"]
        else:
            variant |= _variant(params, asked, code, aspect, given, folder, out_dir, settings,
                                replay, seen)
        (folder / VARIANT_FILE).write_text(json.dumps(variant, indent=1), encoding="utf-8")
        trace.event("variant", **variant)
        found.append(variant)
    return found


def asked_params(params: dict, aspect: str, matcher: Any, round_number: int = 0) -> dict:
    """The record as a variant of ``aspect`` must play it (``round_number``: how many of this
    aspect were asked before): as it is for the weather, which the LLM chooses; with one
    vehicle another model, with a background vehicle in a lane the record leaves free, or one
    lane over. Raises :class:`NotAsked`."""
    if aspect == "lane":
        try:
            return matcher.lane_over(params, round_number)
        except SpawnDbError as err:
            raise NotAsked("VARY_NO_LANE", str(err)) from err
    if aspect == "traffic":
        try:
            return matcher.background(params, round_number)
        except SpawnDbError as err:
            raise NotAsked("VARY_NO_ROOM", str(err)) from err
    if aspect != "vehicles":
        return params
    actors = _vehicle_actors(params)
    if not actors:
        raise NotAsked("VARY_NO_VEHICLE", "the record has no vehicle but the ego")
    actor = actors[round_number % len(actors)]
    others = [t for t in VEHICLE_TYPES if t != known_type(params[f"{actor}_vehicle_type"])]
    model = others[(round_number // len(actors)) % len(others)]
    try:
        return matcher.place_at(with_vehicle_type(params, actor, model))
    except SpawnDbError as err:
        raise NotAsked("VARY_NO_ROOM", str(err)) from err


def _vehicle_actors(params: Mapping[str, Any]) -> list[str]:
    """The params prefixes of the recorded actors besides the ego (each has a model)."""
    actors = []
    for key in params:
        actor = key.removesuffix("_vehicle_type")
        present = params.get("has_npc") if actor == "npc" else params.get(f"{actor}_present")
        if key.endswith("_vehicle_type") and present:
            actors.append(actor)
    return actors


def _variant(params: dict, asked: dict, code: str, aspect: str, given: dict,
             folder: Path, out_dir: Path, settings: AgentSettings, replay: Any,
             seen: set[str]) -> dict:
    found: dict[str, Any] = {"asked": _changes(params, asked)}
    if "ego_lane_id" in found["asked"]:
        found["placed"] = {key: asked.get(key) for key in PLACEMENT_KEYS}
    reference = None
    if found["asked"]:
        (folder / PARAMS_NAME).write_text(json.dumps(asked, indent=1), encoding="utf-8")
        reference = folder / REFERENCE_NAME
        corpus.generate(asked, reference)
    edits = settings.repair == EDIT_STRATEGY
    reply = shared_llm(settings).complete(variant_prompt(params, code, aspect, asked, edits))
    try:
        written = apply_edits(code, reply.text)[0] if edits else extract_python_code(
            reply.text).code
    except PatchError as err:
        return found | {"errors": [f"VARY_EDIT: {err}"]}
    (folder / CODE_NAME).write_text(written, encoding="utf-8")
    if not written:
        return found | {"errors": ["the reply held no Python code"]}
    result = shared_sandbox(settings).run(written, given, folder)
    scenario = folder / XOSC_NAME
    if not result.ok or not scenario.is_file():
        return found | {"errors": [f"{result.error_type or 'NoOutput'}: "
                                   f"{result.error_message or 'no scenario written'}"]}
    variation = compare(out_dir / XOSC_NAME, scenario, reference)
    errors = [f"{f.code}: {f.message}" for f in variation.violations]
    if not variation.changed:
        errors.append("VARY_NOTHING: the variant is the faithful scenario")
    errors += _replay_errors(scenario, asked if variation.as_asked else params, replay)
    digest = _digest(scenario)
    if not errors and digest in seen:
        errors.append("VARY_DUPLICATE: an earlier variant is the same file")
    seen.add(digest)
    return found | {"changed": variation.changed, "kept": not errors, "errors": errors}


def _changes(params: Mapping[str, Any], asked: dict) -> dict[str, list]:
    """``key: [old, new]`` of each value ``asked`` changes."""
    return {key: [params.get(key), value] for key, value in asked.items()
            if params.get(key) != value}


def _replay_errors(scenario: Path, params: Mapping[str, Any], replay: Any) -> list[str]:
    """Valid and playing the record, against its params with the variant's own weather (the
    one value the record fixes that a variant may change)."""
    from lxml import etree

    from scenweave.judge import validate_xosc
    from scenweave.judge.scenario_doc import ScenarioDoc

    weather = ScenarioDoc(etree.parse(str(scenario))).weather_name
    judged = cast(Params, {**params, "weather_key": weather or params["weather_key"]})
    result = validate_xosc(scenario, judged, replay=replay)
    if isinstance(result.playback, Playback):  # what it played, beside it (replay.json)
        result.playback.write(scenario.with_name(REPLAY_NAME))
    return [f"{f.code}: {f.message}" for f in result.errors if f.severity == "error"]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()

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

The weather is the LLM's to choose. What a vehicle model, background traffic and the lane
make of the record is worked out before the agent (``ingest.variants.vary``, called by the
pipeline): the agent gets those params (``judge.variation.Asked``) and hands the LLM the values
that change. The reference script played with them (``reference.xosc`` beside the variant, its
params in ``params.json``) is what such a variant must match in everything the record fixes.
A variant the record leaves no room for comes with its reason and costs no LLM call.

With the ``patch`` strategy the LLM answers with JSON line edits of the delivered script, held
to the same grammar as its repairs, instead of the whole script.

Each variant gets ``variants/vNN/`` in the scenario folder: its script, its scenario when it
ran, and ``variant.json`` (what it changed, what it was asked to change, kept or why not).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, cast

from scenweave import corpus
from scenweave.agent.code import PatchError, extract_python_code
from scenweave.agent.edits import apply_edits
from scenweave.agent.prompts import variant_prompt
from scenweave.agent.run import shared_llm, shared_sandbox
from scenweave.agent.settings import AgentSettings
from scenweave.agent.trace import Trace
from scenweave.corpus.worked_example import provenance, worked_example
from scenweave.judge.variation import Asked, compare
from scenweave.schemas.params import Params
from scenweave.schemas.scenario_folder import (
    CODE_NAME,
    PARAMS_NAME,
    REFERENCE_NAME,
    VARIANT_NAME,
    VARIANTS_DIR,
    XOSC_NAME,
)

#: where ``variant.json`` says a lane variant put the record
PLACEMENT_KEYS = ("spawn_id", "ego_road_id", "ego_lane_id", "ego_s")
#: the repair strategy whose variants are JSON line edits of the script (held to a grammar)
EDIT_STRATEGY = "patch"


def make_variants(params: Params, asked: list[Asked], out_dir: Path, settings: AgentSettings,
                  replay: Any, parametric: bool, trace: Trace) -> list[dict]:
    """One variant of the scenario in ``out_dir`` per ``asked`` (what each is to play, in
    order); what each changed, kept or not.

    ``parametric``: the delivered script is the reference (a fallback), which reads params;
    the variants then start from the record's worked example (its values written in, the
    same scenario), so that each is a change of values, as when the LLM delivered.
    """
    code = (worked_example(corpus.retrieve(params).script_path, params) if parametric
            else (out_dir / CODE_NAME).read_text(encoding="utf-8"))
    given = provenance(params)
    seen = {_digest(out_dir / XOSC_NAME)}
    found = []
    for number, ask in enumerate(asked, start=1):
        folder = out_dir / VARIANTS_DIR / f"v{number:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        variant: dict[str, Any] = {"id": folder.name, "aspect": ask.aspect, "kept": False,
                                   "changed": [], "asked": {}, "errors": []}
        if ask.params is None:
            variant["errors"] = [ask.error or "not asked"]
        else:
            variant |= _variant(params, ask.params, code, ask.aspect, given, folder, out_dir,
                                settings, replay, seen)
        (folder / VARIANT_NAME).write_text(json.dumps(variant, indent=1), encoding="utf-8")
        trace.event("variant", **variant)
        found.append(variant)
    return found


def _variant(params: Params, asked: Params, code: str, aspect: str, given: dict,
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


def _changes(params: Params, asked: Params) -> dict[str, list]:
    """``key: [old, new]`` of each value ``asked`` changes."""
    return {key: [params.get(key), value] for key, value in asked.items()
            if params.get(key) != value}


def _replay_errors(scenario: Path, params: Params, replay: Any) -> list[str]:
    """Valid and playing the record, against its params with the variant's own weather (the
    one value the record fixes that a variant may change)."""
    from lxml import etree

    from scenweave.judge import validate_xosc
    from scenweave.judge.scenario_doc import ScenarioDoc

    weather = ScenarioDoc(etree.parse(str(scenario))).weather_name
    judged = cast(Params, {**params, "weather_key": weather or params["weather_key"]})
    result = validate_xosc(scenario, judged, replay=replay)
    result.write_replay(scenario.parent)  # what it played and the verdict, beside it
    return [f"{f.code}: {f.message}" for f in result.errors if f.severity == "error"]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()

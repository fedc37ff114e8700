"""Variants of a delivered scenario (``scenweave run --vary N``): the LLM rewrites the final
script changing one thing the record does not fix (weather and time of day, a vehicle model,
background traffic, the lane; ``schemas.variation.ASPECTS`` in turn), and a variant is kept
only when

- it runs in the sandbox, given what the delivered script was given;
- it changes what it may and nothing the record fixes (``schemas.variation.compare``);
- it is valid and still plays the recorded manoeuvre (``validate_xosc`` with the replay,
  against the record's params with the variant's own weather);
- no kept variant of the record is the same file.

Each variant gets ``variants/vNN/`` in the scenario folder: its script, its scenario when it
ran, and ``variant.json`` (what it changed, kept or why not).
"""

from __future__ import annotations

import hashlib
import json
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

VARIANTS_DIR = "variants"
VARIANT_FILE = "variant.json"


def make_variants(params: dict, out_dir: Path, settings: AgentSettings, count: int,
                  replay: Any, parametric: bool, trace: Trace) -> list[dict]:
    """``count`` variants of the scenario in ``out_dir``; what each changed, kept or not.

    ``parametric``: the delivered script is the reference (a fallback), which reads params.
    """
    code = (out_dir / CODE_NAME).read_text(encoding="utf-8")
    given = params if parametric else provenance(params)
    seen = {_digest(out_dir / XOSC_NAME)}
    found = []
    for number in range(1, count + 1):
        aspect = ASPECTS[(number - 1) % len(ASPECTS)]
        folder = out_dir / VARIANTS_DIR / f"v{number:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        variant = _variant(params, code, aspect, given, folder, out_dir, settings, replay, seen)
        (folder / VARIANT_FILE).write_text(json.dumps(variant, indent=1), encoding="utf-8")
        trace.event("variant", **variant)
        found.append(variant)
    return found


def _variant(params: dict, code: str, aspect: str, given: dict, folder: Path, out_dir: Path,
             settings: AgentSettings, replay: Any, seen: set[str]) -> dict:
    found: dict[str, Any] = {"id": folder.name, "aspect": aspect, "kept": False,
                             "changed": [], "errors": []}
    reply = shared_llm(settings).complete(variant_prompt(params, code, aspect))
    written = extract_python_code(reply.text).code
    (folder / CODE_NAME).write_text(written, encoding="utf-8")
    if not written:
        return found | {"errors": ["the reply held no Python code"]}
    result = shared_sandbox(settings).run(written, given, folder)
    scenario = folder / XOSC_NAME
    if not result.ok or not scenario.is_file():
        return found | {"errors": [f"{result.error_type or 'NoOutput'}: "
                                   f"{result.error_message or 'no scenario written'}"]}
    variation = compare(out_dir / XOSC_NAME, scenario)
    found["changed"] = variation.changed
    errors = [f"{f.code}: {f.message}" for f in variation.violations]
    if not variation.changed:
        errors.append("VARY_NOTHING: the variant is the faithful scenario")
    errors += _replay_errors(scenario, _shifted_params(params, variation.lane_shift), replay)
    digest = _digest(scenario)
    if not errors and digest in seen:
        errors.append("VARY_DUPLICATE: an earlier variant is the same file")
    seen.add(digest)
    return found | {"kept": not errors, "errors": errors}


def _shifted_params(params: dict, lanes: int) -> dict:
    """The record's params with every placed actor's lane moved by ``lanes`` (a lane
    variant); the spawn keys name lanes as OpenDRIVE ids."""
    if not lanes:
        return params
    return {**params, **{key: value + lanes for key, value in params.items()
                         if key.endswith("_lane_id") and isinstance(value, int)}}


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

"""The prompts: thesis Table 5.5 (six sections), the error-aware re-prompt (Table 5.6) and
the patch prompt, which asks for a small edit to the reference instead of the whole script.

The script shown is the reference's worked example (``corpus.worked_example``): another
record's values written in. The PARAMETERS JSON holds the values of this record the script
plays, by the same keys; the LLM writes them in place of the example's."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from scenweave.agent.edits import edit_schema, value_edit_grammar
from scenweave.agent.llm.base import Prompt
from scenweave.corpus.worked_example import python_literal, written_values

#: params keys that describe where a record came from, not the scenario (kept from the LLM)
METADATA_KEYS = frozenset({"scenario_id", "source_file", "source_row", "record_id",
                           "spawn_id", "description", "variant_of"})

SYSTEM = ("You output only Python code. No explanations. "
          "Start directly with import statements.")
PATCH_SYSTEM = ("You output only JSON edits in the exact format you are shown. "
                "No explanations.")

TASK = ("You are given a complete, working Python script for a CARLA {maneuver} scenario, "
        "written for another record: its values are written into RECORD and into generate().")
CONSTRAINTS = ("OUTPUT THE ENTIRE SCRIPT BELOW, replacing ONLY the values: RECORD must hold "
               "exactly the keys and values of the PARAMETERS JSON, and every value written "
               "into generate() must be the JSON's value of the same key. generate() is given "
               "only scenario_id in params: never read a value from params. DO NOT simplify, "
               "summarize, or stub any function. Keep generate(params, out_path) and every "
               "import.")
OUTPUT_CUE = "Output the complete Python script starting with imports."

ERROR_TASK = ("Your previous script for this CARLA {maneuver} scenario failed. "
              "The error and your script are below.")
ERROR_CONSTRAINTS = ("Reproduce the REFERENCE SCRIPT VERBATIM, replacing ONLY its values "
                     "with those of the same keys in the JSON. Do not invent functions, "
                     "attributes or modules: use only what the reference script uses.")

#: the form of a JSON edit reply, shown to the model (valid JSON: ``json.dumps`` writes it)
EDIT_EXAMPLE = json.dumps({"edits": [{"search": '    "speed": 1.0,',
                                      "replace": '    "speed": 2.5,'}]})
PATCH_FORMAT = f"""JSON, one edit per line to change:
{EDIT_EXAMPLE}
Change each value listed below, in RECORD and wherever generate() has it written in; add a
value the script does not have yet to RECORD. If nothing is listed: {{"edits": []}}"""


def llm_params(params: Mapping[str, Any], values: dict | None = None) -> dict:
    """The params the LLM sees: the record's ``values`` the script plays, else everything
    but metadata (thesis Table 5.5)."""
    if values is not None:
        return values
    return {k: v for k, v in params.items() if k not in METADATA_KEYS}


def maneuver_name(params: Mapping[str, Any]) -> str:
    name = params.get("maneuver_tag") or params.get("maneuver_class", "driving")
    return str(name).replace("_", " ")


def generation_prompt(params: Mapping[str, Any], reference: str,
                      values: dict | None = None) -> Prompt:
    """Attempt 1: the six sections of thesis Table 5.5."""
    user = _sections(*_shared_head(params, reference, values), ("OUTPUT", OUTPUT_CUE))
    return Prompt(SYSTEM, user, params.get("scenario_id", ""), "generate")


def error_prompt(params: Mapping[str, Any], reference: str, failed_code: str, error: str,
                 values: dict | None = None) -> Prompt:
    """Attempts 2 and 3 (thesis Table 5.6): previous code and its error injected.

    It begins exactly like the first prompt, so a local model reuses its cached prefix
    (llama.cpp keeps the longest common prefix) and reads only the new sections.
    """
    user = _sections(
        *_shared_head(params, reference, values),
        ("YOUR PREVIOUS SCRIPT FAILED", ERROR_TASK.format(maneuver=maneuver_name(params))),
        ("ERROR", _fenced(error, "text")),
        ("YOUR PREVIOUS SCRIPT", _fenced(failed_code)),
        ("CONSTRAINTS FOR THE RETRY", ERROR_CONSTRAINTS),
        ("OUTPUT", OUTPUT_CUE),
    )
    return Prompt(SYSTEM, user, params.get("scenario_id", ""), "repair")


def patch_prompt(params: Mapping[str, Any], reference: str, error: str | None = None,
                 values: dict | None = None) -> Prompt:
    """Ask for JSON edits against the worked example (their schema rides along for backends
    that constrain decoding); after a failure, with the error."""
    shown, wanted = written_values(reference), llm_params(params, values)
    sections = [
        ("TASK", TASK.format(maneuver=maneuver_name(params))
         + " Adapt it to this record's values with the smallest edit."),
        ("FORMAT", PATCH_FORMAT),
        ("REFERENCE SCRIPT", _fenced(reference)),
        ("VALUES TO CHANGE", value_changes(shown, wanted)) if shown is not None
        else ("PARAMETERS JSON", _params_json(params, values)),
    ]
    if error:
        sections.append(("ERROR OF YOUR PREVIOUS EDIT", _fenced(error, "text")))
    sections.append(("OUTPUT", "Output only the JSON edits."))
    grammar = value_edit_grammar(reference, _new_keys(reference, wanted),
                                 _changed_entries(shown, wanted))
    return Prompt(PATCH_SYSTEM, _sections(*sections), params.get("scenario_id", ""),
                  "repair" if error else "generate", edit_schema(reference), grammar)


def _shared_head(params: Mapping[str, Any], reference: str,
                 values: dict | None) -> list[tuple[str, str]]:
    return [
        ("TASK", TASK.format(maneuver=maneuver_name(params))),
        ("CONSTRAINTS", CONSTRAINTS),
        ("REFERENCE SCRIPT", _fenced(reference)),
        ("PARAMETERS JSON", _params_json(params, values)),
    ]


def _sections(*sections: tuple[str, str]) -> str:
    return "\n\n".join(f"### {title}\n{body}" for title, body in sections)


def _fenced(text: str, lang: str = "python") -> str:
    return f"```{lang}\n{text.rstrip()}\n```"


def _params_json(params: Mapping[str, Any], values: dict | None = None) -> str:
    return _fenced(json.dumps(llm_params(params, values), indent=1), "json")


VARIANT_TASK = ("You are given a working Python script for a CARLA {maneuver} scenario that "
                "plays back a recorded manoeuvre. Write a variant of it.")
VARIANT_CONSTRAINTS = ("Every number of the manoeuvre stays as it is: speeds, distances, times, "
                       "lanes and positions of the recorded vehicles, the light. Change only "
                       "what is asked below. Keep the function generate(params, out_path) and "
                       "every import.")
VARIANT_EDIT_FORMAT = f"""JSON, one edit per line to change:
{EDIT_EXAMPLE}
A "replace" may hold several lines (joined by \\n) to add lines after the one searched."""
#: what each aspect of a variant asks for (judge.variation.ASPECTS)
VARIANT_CHANGES = {
    "weather": ("Change only the weather and time of day: set the \"weather_key\" value to "
                "another of Day_Clear, Day_Cloudy, Day_Rain, Day_Fog, Night_Clear, Night_Rain, "
                "Night_Fog."),
    "vehicles": ("Change one vehicle model. The record's distances are between bumpers, so "
                 "a longer or shorter vehicle stands elsewhere: change these values wherever "
                 "the script has them, from the old value to the new one, and nothing "
                 "else:\n{moves}"),
    "traffic": ("Add one background vehicle that keeps clear of the manoeuvre. "
                "make_scenario() adds it when the params it is given hold these keys: add "
                "each with its value to what generate() passes to make_scenario() (RECORD, "
                "where the script has one), and change nothing else:\n{moves}"),
    "lane": ("Move the whole scenario one lane over, where the map has room for it: change "
             "these values wherever the script has them, from the old value to the new one, "
             "and nothing else:\n{moves}"),
}


def variant_prompt(params: Mapping[str, Any], code: str, aspect: str,
                   asked: Mapping[str, Any] | None = None, edits: bool = False) -> Prompt:
    """A variant of the delivered scenario script that changes one ``aspect`` only;
    ``asked``: the record as the variant must play it (``ingest.variants.vary``), whose
    changed values the request lists. ``edits``: ask for JSON line edits of the script (the
    ``patch`` strategy, held to its grammar) instead of the whole script."""
    asked = asked or params
    named = {key: value for key, value in asked.items() if _names(code, key)}
    change = VARIANT_CHANGES[aspect].format(moves=value_changes(
        params, named if value_changes(params, named) else asked))
    head = [("TASK", VARIANT_TASK.format(maneuver=maneuver_name(params))),
            ("CONSTRAINTS", VARIANT_CONSTRAINTS), ("CHANGE", change)]
    purpose = f"vary-{aspect}"
    if edits:
        user = _sections(*head, ("FORMAT", VARIANT_EDIT_FORMAT), ("SCRIPT", _fenced(code)),
                         ("OUTPUT", "Output only the JSON edits."))
        changed = {key: value for key, value in asked.items() if params.get(key) != value}
        grammar = value_edit_grammar(code, _new_keys(code, changed),
                                     _changed_entries(written_values(code), changed))
        return Prompt(PATCH_SYSTEM, user, params.get("scenario_id", ""), purpose,
                      edit_schema(code), grammar)
    user = _sections(*head, ("SCRIPT", _fenced(code)), ("OUTPUT", OUTPUT_CUE))
    return Prompt(SYSTEM, user, params.get("scenario_id", ""), purpose)


def value_changes(before: Mapping[str, Any], after: Mapping[str, Any]) -> str:
    """``- key: old -> new`` (Python literals, as a script writes them) for each value of
    ``after`` that ``before`` holds otherwise; ``- key: new`` for one it does not hold."""
    return "\n".join(
        f"- {key}: {python_literal(before[key])} -> {python_literal(value)}"
        if before.get(key) is not None else f"- {key}: {python_literal(value)}"
        for key, value in after.items()
        if key not in METADATA_KEYS and (key not in before or before[key] != value))


def _names(code: str, key: str) -> bool:
    return f'"{key}"' in code or f"'{key}'" in code


def _new_keys(script: str, values: dict) -> tuple[str, ...]:
    """The keys of ``values`` the script's dicts do not hold yet (an edit may add them)."""
    return tuple(key for key in values if f'"{key}":' not in script
                 and key not in METADATA_KEYS)


def _changed_entries(shown: dict | None, wanted: dict) -> int:
    """How many ``RECORD`` entries must change (each is a line an edit names)."""
    if shown is None:
        return 0
    return sum(1 for key, value in wanted.items() if key in shown and shown[key] != value
               and key not in METADATA_KEYS)

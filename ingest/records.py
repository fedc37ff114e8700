"""Checking canonical records against their JSON Schemas, and reading them back."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from functools import cache
from pathlib import Path

import fastjsonschema

from scenweave import maneuvers
from scenweave.ingest.issues import IngestError, RecordIssue
from scenweave.maneuvers import Domain
from scenweave.schemas import load_json_schema

SCHEMA_OF_DOMAIN = {"highway": "highway_record", "urban": "urban_record"}
#: the classes a record schema's condition names (its ``$comment``), from the registry
CLASS_GROUPS: dict[str, Callable[[maneuvers.Maneuver], bool]] = {
    "registry: relative_speed": lambda m: m.relative_speed,
    "registry: behavior_type": lambda m: "behavior_type" in m.layout_fields,
}


def record_schema(domain: Domain) -> dict:
    """The JSON Schema of a domain's records, its ``maneuver_class`` (and, where the schema
    lists them, ``maneuver_tag``) limited to the classes registered for that domain."""
    schema = load_json_schema(SCHEMA_OF_DOMAIN[domain])
    schema["properties"]["maneuver_class"]["enum"] = maneuvers.codes(domain)
    if "enum" in schema["properties"]["maneuver_tag"]:
        schema["properties"]["maneuver_tag"]["enum"] = list(dict.fromkeys(
            m.tag for m in maneuvers.maneuvers(domain)))
    for condition in schema.get("allOf", ()):
        which = condition["if"]["properties"].get("maneuver_class", {})
        if which.get("$comment") in CLASS_GROUPS:
            which["enum"] = [m.code for m in maneuvers.maneuvers(domain)
                             if CLASS_GROUPS[which["$comment"]](m)]
    return schema


@cache
def _compiled(domain: Domain, known: tuple[str, ...]) -> Callable[[dict], dict]:
    return fastjsonschema.compile(record_schema(domain))


def record_domain(record: dict) -> Domain:
    return "highway" if record.get("domain") == "highway" else "urban"


def schema_name(record: dict) -> str:
    """Which JSON Schema a record answers to."""
    return SCHEMA_OF_DOMAIN[record_domain(record)]


def check_record(record: dict) -> None:
    """Raise RecordIssue naming the field when ``record`` breaks its JSON Schema."""
    domain = record_domain(record)
    try:
        _compiled(domain, tuple(maneuvers.codes(domain)))(record)
    except fastjsonschema.JsonSchemaValueException as err:
        field = (err.name or "").removeprefix("data.").removeprefix("data") or None
        raise RecordIssue(f"record breaks {schema_name(record)}.schema.json: {err.message}",
                          field=field) from err


def load_records(path: Path | str) -> Iterator[dict]:
    """Canonical records from an ingest output folder (``highway/``, ``urban/``) or one file."""
    path = Path(path)
    files = [path] if path.is_file() else sorted(
        p for sub in ("highway", "urban") for p in (path / sub).glob("*.json"))
    if not files:
        raise IngestError(f"no canonical records in {path} (expected highway/*.json or "
                          f"urban/*.json written by 'scenweave ingest')")
    for file in files:
        try:
            data = json.loads(file.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
            raise IngestError(f"{file}: cannot read canonical records: {err}") from err
        yield from data if isinstance(data, list) else [data]

"""The contracts between the stages: column layouts (``highway_layouts.json``), the records'
JSON Schemas, the params contract (``params``), the ADScene code tables and the OpenSCENARIO
1.0 XSD (``xsd``). Judging a scenario against them is ``scenweave.judge``'s."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

__all__ = ["load_json_schema"]

SCHEMAS_DIR = Path(__file__).resolve().parent


@cache
def load_json_schema(name: str) -> dict[str, Any]:
    """Load ``schemas/<name>.schema.json`` (cached per process)."""
    schema: dict[str, Any] = json.loads((SCHEMAS_DIR / f"{name}.schema.json").read_text(
        encoding="utf-8"))
    return schema

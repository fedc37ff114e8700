"""Schemas and validation: column layouts, JSON Schemas, the OpenSCENARIO XSD, validate_xosc."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

from scenweave.schemas.findings import Finding, ValidationResult, failure_category
from scenweave.schemas.qc import run_asam_qc
from scenweave.schemas.validate_xosc import validate_tree, validate_xosc

__all__ = ["Finding", "ValidationResult", "failure_category", "load_json_schema", "run_asam_qc",
           "validate_tree", "validate_xosc"]

SCHEMAS_DIR = Path(__file__).resolve().parent


@cache
def load_json_schema(name: str) -> dict[str, Any]:
    """Load ``schemas/<name>.schema.json`` (cached per process)."""
    return json.loads((SCHEMAS_DIR / f"{name}.schema.json").read_text(encoding="utf-8"))

"""ADScene RT_* code tables (thesis Appendix A.6), loaded from ``schemas/adscene_codes.json``."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

CODES_PATH = Path(__file__).resolve().parent.parent / "schemas" / "adscene_codes.json"
#: records give codes as numbers (167 or 167.0)
TRAFFIC_LIGHT_STATES: dict[float, str] = {167: "green", 170: "orange", 172: "red"}


@cache
def code_tables() -> dict[str, dict[str, str]]:
    """All tables: ``{"RT_Precipitation": {"0": "No Rainfall", ...}, ...}``."""
    tables = json.loads(CODES_PATH.read_text(encoding="utf-8"))
    return {name: table for name, table in tables.items() if name.startswith("RT_")}


def decode(table: str, code: object) -> str:
    """The label of ``code`` in ``table``; unknown codes read ``Unknown (<code>)``."""
    key = str(int(code)) if isinstance(code, float) and code.is_integer() else str(code)
    entries = code_tables()[table]
    if key in entries:
        return entries[key]
    padded = key.zfill(3)
    return entries.get(padded, f"Unknown ({code})")

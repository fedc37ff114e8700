"""The detection thresholds (``mining/thresholds.json``): data, not code.

A user's file (``scenweave mine --thresholds FILE``) must give every number the bundled file
gives; a missing or non-numeric one is an error naming it, an unknown one a warning.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from scenweave.errors import InputError

DEFAULT_THRESHOLDS = Path(__file__).with_name("thresholds.json")


class ThresholdsError(InputError, ValueError):
    """A thresholds file ScenWeave cannot use; the message names the file and the key."""


def load_thresholds(path: Path | str | None = None,
                    warnings: list[str] | None = None) -> dict[str, dict[str, float]]:
    """Section -> name -> number; the bundled values where ``path`` is None."""
    bundled = _read(DEFAULT_THRESHOLDS)
    given = bundled if path is None else _read(Path(path))
    found: dict[str, dict[str, float]] = {}
    for section, numbers in bundled.items():
        if not isinstance(numbers, dict):
            continue
        theirs = given.get(section)
        if not isinstance(theirs, dict):
            raise ThresholdsError(f"{path}: section {section!r} is missing")
        found[section] = {}
        for name in (n for n in numbers if n != "doc"):
            value = theirs.get(name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ThresholdsError(f"{path}: {section}.{name} must be a number, got {value!r}")
            found[section][name] = float(value)
        extra = sorted(set(theirs) - set(numbers))
        if extra and warnings is not None:
            warnings.append(f"{path}: unknown key(s) in {section}: {', '.join(extra)} (ignored)")
    return found


def _read(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ThresholdsError(f"{path}: cannot read thresholds: {err}") from err
    if not isinstance(data, dict):
        raise ThresholdsError(f"{path}: must hold a JSON object")
    return data

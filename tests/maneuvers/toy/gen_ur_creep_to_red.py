"""Creep up to a red light and stop at its line: the stop-at-red scenario, as the toy urban
class U9_1 records it (its params name their own class and tag)."""

from __future__ import annotations

import importlib
from typing import Any


def generate(params: dict[str, Any], out_path: str) -> Any:
    stop_at_red = importlib.import_module("scenweave.corpus.gen_ur_stop_at_tfl_red")
    return stop_at_red.generate(params, out_path)

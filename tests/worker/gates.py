"""A spawn matcher with gates the tests control through files, to make worker tests
deterministic: the real Town04 ``SpawnMatcher`` behind it does the actual work.

In ``$SCENWEAVE_TEST_GATES`` (a folder), for a scenario whose folder name is ``S``:
``block-S`` makes its job write ``started-S`` (the horse's pid) and wait for ``release``;
``infra-S`` holding N makes its first N attempts raise ConnectionError (an LLM server that
cannot be reached); ``bad-S`` makes every attempt raise ValueError (a scenario's own fault).
Every attempt appends its pid to ``attempts-S``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

from scenweave.run_folder import safe_name
from scenweave.runner import default_matcher

GATES_ENV = "SCENWEAVE_TEST_GATES"


class GatedMatcher:
    """SpawnMatcher.assign behind the file gates described in the module docstring."""

    def __init__(self, map_name: str | None = None) -> None:
        self.inner = default_matcher(map_name)

    def assign(self, params: dict, index: int, top_n: int = 5) -> dict[str, Any]:
        gates = Path(os.environ[GATES_ENV])
        name = safe_name(params["scenario_id"])
        with open(gates / f"attempts-{name}", "a") as log:
            log.write(f"{os.getpid()}\n")
        attempts = len((gates / f"attempts-{name}").read_text().split())
        if (gates / f"block-{name}").exists():
            (gates / f"started-{name}").write_text(str(os.getpid()))
            deadline = time.monotonic() + 120
            while not (gates / "release").exists() and time.monotonic() < deadline:
                time.sleep(0.05)
        infra = gates / f"infra-{name}"
        if infra.exists() and attempts <= int(infra.read_text()):
            raise ConnectionError(f"LLM server unreachable (test gate, attempt {attempts})")
        if (gates / f"bad-{name}").exists():
            raise ValueError("a scenario's own fault (test gate)")
        return self.inner.assign(params, index, top_n=top_n)

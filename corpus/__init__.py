"""The reference corpus: 16 scenario scripts, their worked examples and retrieval.

``retrieve(params_or_query)`` picks a script (keyword, tag table, semantic fallback),
``generate(params, out_path)`` runs it in-process (the deterministic ``--no-llm`` path),
``list_scripts()`` lists them. The scripts build their scenarios with the scenario library
(``scenweave.scenario_lib``), the one folder the sandbox has; this one stays on the host.
Scenario layout: ``docs/scenario-conventions.md``.

The names below load on first use: importing the package (or a reference script in it) does
not pull in retrieval, the registry or the error root.
"""

from __future__ import annotations

import importlib
from typing import Any

#: name -> the module that defines it, imported when the name is first used
_LAZY = {"Retrieval": "retrieval", "generate": "retrieval", "list_scripts": "retrieval",
         "retrieve": "retrieval", "CorpusError": "errors"}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'scenweave.corpus' has no attribute {name!r}")
    return getattr(importlib.import_module(f"scenweave.corpus.{_LAZY[name]}"), name)

"""The reference corpus: 16 scenario scripts, their shared building blocks and retrieval.

``retrieve(params_or_query)`` picks a script (keyword, tag table, semantic fallback),
``generate(params, out_path)`` runs it in-process (the deterministic ``--no-llm`` path),
``list_scripts()`` lists them. Scenario layout: ``docs/scenario-conventions.md``.
"""

from scenweave.corpus.errors import CorpusError, ParamsError
from scenweave.corpus.retrieval import MANEUVER_TAGS, Retrieval, generate, list_scripts, retrieve

__all__ = ["MANEUVER_TAGS", "CorpusError", "ParamsError", "Retrieval", "generate", "list_scripts",
           "retrieve"]

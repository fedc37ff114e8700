"""The corpus package's root exception."""

from scenweave.errors import ScenarioError, ScenWeaveError


class CorpusError(ScenWeaveError):
    """Root of the corpus package's errors (missing scripts, no match, model not installed)."""


class ParamsError(CorpusError, ScenarioError, ValueError):
    """A params dict a reference script cannot build a scenario from (names the key)."""

"""The corpus package's root exception."""


class CorpusError(Exception):
    """Root of the corpus package's errors (missing scripts, no match, model not installed)."""


class ParamsError(CorpusError, ValueError):
    """A params dict a reference script cannot build a scenario from (names the key)."""

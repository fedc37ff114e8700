"""The corpus package's root exception; a script's params problem is ``errors.ParamsError``."""

from scenweave.errors import ScenWeaveError


class CorpusError(ScenWeaveError):
    """Root of the corpus package's errors (missing scripts, no match, model not installed)."""

"""The error taxonomy of a failed attempt (thesis §6.1, extended): one word per failure."""

from __future__ import annotations

import re

CATEGORIES = ("syntax", "api_hallucination", "name", "import", "timeout", "runtime",
              "validation", "fidelity")

BY_ERROR_TYPE = {
    "SyntaxError": "syntax", "IndentationError": "syntax", "TabError": "syntax",
    "EmptyCode": "syntax", "PatchError": "syntax",
    "NameError": "name", "UnboundLocalError": "name",
    "ImportError": "import", "ModuleNotFoundError": "import",
    "AttributeError": "api_hallucination",
    "Timeout": "timeout", "LLMTimeout": "timeout",
}
#: a TypeError about the call itself means the LLM invented a signature
HALLUCINATED_SIGNATURE = re.compile(
    r"unexpected keyword argument|positional argument|required (?:positional|keyword)"
    r"|takes \d+ .*given|missing \d+ required|object is not callable")


def classify_exception(error_type: str | None, message: str | None = "") -> str:
    """The category of an exception the script raised (by name, as the sandbox reports it)."""
    name = error_type or ""
    if name in BY_ERROR_TYPE:
        return BY_ERROR_TYPE[name]
    if name == "TypeError" and HALLUCINATED_SIGNATURE.search(message or ""):
        return "api_hallucination"
    return "runtime"


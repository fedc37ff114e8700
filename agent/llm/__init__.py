"""LLM backends behind one small interface: ``get_llm(settings).complete(prompt)``.

``ollama`` (a server through the official client), ``embedded`` (a GGUF model in-process via
llama-cpp-python, SmolLM2-135M by default) and ``replay`` (recorded replies, for tests and for
re-running a past trace). They are named in ``agent.llm.backends`` exactly as a plugin names
its own (``LLM_BACKENDS``; ``docs/plugins.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from scenweave.agent.llm.backends import LLM_BACKENDS, backend_names, find_backend
from scenweave.agent.llm.base import LLM, LLMReply, LLMTimeout, LLMUnavailable, Prompt
from scenweave.plugins import DOCS

if TYPE_CHECKING:
    from scenweave.agent.settings import AgentSettings

__all__ = ["LLM", "LLM_BACKENDS", "LLMReply", "LLMTimeout", "LLMUnavailable", "Prompt",
           "backend_names", "get_llm"]


def get_llm(settings: AgentSettings) -> LLM:
    """The backend ``settings.llm`` names, constructed from ``settings``."""
    make = find_backend(settings.llm)
    if make is None:
        raise LLMUnavailable(f"--llm {settings.llm}: no such LLM backend (choose "
                             f"{', '.join(backend_names())}; plugins add more, see {DOCS})")
    return make(settings)

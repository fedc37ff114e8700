"""LLM backends behind one small interface: ``get_llm(settings).complete(prompt)``.

``ollama`` (a server through the official client), ``embedded`` (a GGUF model in-process via
llama-cpp-python, SmolLM2-135M by default) and ``replay`` (recorded replies, for tests and for
re-running a past trace). Adding a backend is one module and one line in ``BACKENDS``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from scenweave.agent.llm.base import LLM, LLMReply, LLMTimeout, LLMUnavailable, Prompt

if TYPE_CHECKING:
    from scenweave.agent.settings import AgentSettings

__all__ = ["BACKENDS", "LLM", "LLMReply", "LLMTimeout", "LLMUnavailable", "Prompt", "get_llm"]

#: backend name -> "module:class"
BACKENDS = {
    "ollama": "scenweave.agent.llm.ollama:OllamaLLM",
    "embedded": "scenweave.agent.llm.embedded:EmbeddedLLM",
    "replay": "scenweave.agent.llm.replay:ReplayLLM",
}


def get_llm(settings: AgentSettings) -> LLM:
    """The backend ``settings.llm`` names, constructed from ``settings``."""
    try:
        target = BACKENDS[settings.llm]
    except KeyError:
        raise LLMUnavailable(f"--llm {settings.llm}: no such LLM backend "
                             f"(choose {', '.join(BACKENDS)})") from None
    module_name, class_name = target.split(":")
    return getattr(importlib.import_module(module_name), class_name)(settings)

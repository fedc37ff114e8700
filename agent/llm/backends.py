"""The LLM backends by name: the built-in ones, declared below exactly as a plugin declares its
own (``LLM_BACKENDS``: name -> a callable making the backend from the ``AgentSettings``, or
``"module:attribute"`` imported on first use; ``docs/plugins.md``), and the plugins'.

Apart from ``agent.llm`` so that the settings can check ``--llm`` against it: this module
knows the settings only as what a backend is made from.
"""

from __future__ import annotations

from collections.abc import Callable

from scenweave.agent.llm.base import LLM
from scenweave.plugins import Registry

__all__ = ["LLM_BACKENDS", "backend_names", "find_backend"]

LLM_BACKENDS = {
    "ollama": "scenweave.agent.llm.ollama:OllamaLLM",
    "embedded": "scenweave.agent.llm.embedded:EmbeddedLLM",
    "replay": "scenweave.agent.llm.replay:ReplayLLM",
}

_backends: Registry[Callable[..., LLM]] = Registry(
    "LLM backend", "LLM_BACKENDS", expected="a callable making an LLM from the settings",
    accepts=callable, builtin_modules=[__name__])


def backend_names() -> list[str]:
    """Every backend's name: the built-in ones and the plugins'."""
    return _backends.names()


def find_backend(name: str) -> Callable[..., LLM] | None:
    """What makes the backend ``name`` from the settings, or None."""
    return _backends.find(name)

"""A toy plugin (``tests/plugins/test_plugins.py``): a repair strategy that always answers the
reference script, and an LLM backend that echoes the prompt. Loaded with
``SCENWEAVE_PLUGINS=/path/to/toy_plugin.py``; it imports what it extends, ScenWeave imports
nothing of it."""

from __future__ import annotations

from scenweave.agent.llm import LLM, LLMReply, Prompt
from scenweave.agent.repair import Candidate, RepairStrategy, Request


class Reference(RepairStrategy):
    """Gives up on the LLM at once: the reference script is the repair."""

    name = "reference_only"

    def repair(self, request: Request, llm: LLM) -> Candidate:
        return Candidate(request.reference)


class EchoLLM(LLM):
    """Answers every prompt with its own user message."""

    backend = "echo"

    def __init__(self, settings) -> None:
        super().__init__(settings.model_name)

    def _complete(self, prompt: Prompt) -> LLMReply:
        return LLMReply(text=prompt.user)


REPAIR_STRATEGIES = {"reference-only": Reference()}
LLM_BACKENDS = {"echo": EchoLLM}

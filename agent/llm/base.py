"""The one small interface every LLM backend implements (what a call takes and returns lives
in ``agent.llm.messages``, shared with the call log)."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod

from scenweave.agent.llm.log import log_call
from scenweave.agent.llm.messages import LLMReply, Prompt
from scenweave.errors import InfrastructureError

__all__ = ["LLM", "LLMReply", "LLMTimeout", "LLMUnavailable", "Prompt"]


class LLMUnavailable(InfrastructureError):
    """The LLM cannot answer (server unreachable, timed out, model missing, not installed).

    An infrastructure failure, not the scenario's fault: the message names the setting to
    change. The queue worker retries the scenario later; ``scenweave run`` stops on it unless
    ``AgentSettings.on_llm_error`` is ``"fallback"``.
    """


class LLMTimeout(LLMUnavailable):
    """The LLM did not finish one call within ``AgentSettings.timeout_s``."""


class LLM(ABC):
    """A backend: ``complete(prompt)`` returns an :class:`LLMReply` or raises
    :class:`LLMUnavailable`; ``check()`` raises the same before a batch starts."""

    backend = ""

    def __init__(self, model: str) -> None:
        self.model = model
        #: the run its calls are logged under (``AgentSettings.run_id``)
        self.run_id: str | None = None

    def complete(self, prompt: Prompt) -> LLMReply:
        """Ask once; the reply is timed and logged (``$SCENWEAVE_HOME/llm-calls.sqlite``)."""
        started = time.perf_counter()
        reply = self._complete(prompt)
        reply.latency_s = round(time.perf_counter() - started, 4)
        reply.backend, reply.model = self.backend, reply.model or self.model
        log_call(prompt, reply, self.run_id)
        return reply

    def check(self) -> None:  # noqa: B027 - most backends have nothing to check
        """Raise :class:`LLMUnavailable` naming the setting to change if this LLM cannot run."""

    def close(self) -> None:  # noqa: B027 - most backends hold nothing
        """Release what the backend holds (connections, a loaded model)."""

    @abstractmethod
    def _complete(self, prompt: Prompt) -> LLMReply:
        """Backend-specific call; fill text and token counts."""

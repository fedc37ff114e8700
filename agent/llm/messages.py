"""What an LLM call takes and returns: plain data, shared by the backends and the call log."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any


@dataclass(frozen=True)
class Prompt:
    """One request: a system instruction, the user message, and who asks (for logs/replay)."""

    system: str
    user: str
    scenario_id: str = ""
    purpose: str = "generate"  # "generate" or "repair": which node asked
    reply_schema: dict[str, Any] | None = field(default=None, compare=False, hash=False)
    """A JSON schema the reply must follow (Ollama's structured output holds it to it)."""
    reply_grammar: str | None = None
    """The same as a GBNF grammar (the embedded llama.cpp model is held to it)."""

    def messages(self) -> list[dict[str, str]]:
        """The chat messages of this prompt."""
        return [{"role": "system", "content": self.system}, {"role": "user", "content": self.user}]


@dataclass
class LLMReply:
    """The raw text an LLM answered, with its cost."""

    text: str
    tokens_in: int = 0
    tokens_out: int = 0
    latency_s: float = 0.0
    backend: str = ""
    model: str = ""
    meta: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)

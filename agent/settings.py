"""Runtime settings of the agent (model, host, limits), kept apart from the graph's state."""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from scenweave.agent.llm.backends import backend_names
from scenweave.agent.repair import checked_repair
from scenweave.sandbox import SandboxSettings

DEFAULT_MODELS = {"ollama": "qwen2.5-coder:7b", "embedded": "smollm2-135m-instruct",
                  "replay": "replay", "none": "none"}
#: SPEC §6: a small embedded model loops on long outputs; cap what it may write. The longest
#: worked example (the reference with its values written in) is 874 SmolLM2 tokens, so 1024
#: leaves room for the fences and a line of prose.
DEFAULT_MAX_TOKENS = {"ollama": 4096, "embedded": 1024, "replay": 4096, "none": 0}
DEFAULT_OLLAMA_HOST = "http://localhost:11434"
#: sandboxes a batch keeps started ahead (interpreter up, scenariogeneration imported): each
#: attempt still gets its own, but pays ~0.2 s instead of a cold start's 1-2.5 s, the next one
#: starting while the LLM writes the next attempt
BATCH_WARM_POOL = 1


def batch_sandbox(backend: str = "auto") -> SandboxSettings:
    """The sandbox settings of a batch: ``backend`` with a warm pool of ``BATCH_WARM_POOL``."""
    return SandboxSettings(backend=backend, warm_pool=BATCH_WARM_POOL)


@dataclass
class AgentSettings:
    """How the agent talks to its LLM, repairs, and runs code. One per batch."""

    llm: str = "embedded"
    """Backend: ``ollama``, ``embedded`` (GGUF in-process), ``replay`` (recorded replies)."""
    model: str | None = None
    """Model name (Ollama tag, or a GGUF path for embedded); None = the backend's default."""
    repair: str = "error_feedback"
    """Repair strategy by name (``agent.repair.strategy_names()``; dashes or underscores)."""
    max_attempts: int = 3
    """LLM attempts (first + repairs) before the reference script is run directly."""
    temperature: float = 0.1
    top_p: float = 0.9
    max_tokens: int | None = None
    """Output cap per call; None = 4096 for Ollama, 1024 for the embedded model."""
    num_ctx: int = 8192
    """Context window asked of the model (prompt + reply tokens)."""
    repeat_penalty: float = 1.1
    timeout_s: float = 300.0
    """Per LLM call; a call that takes longer raises LLMUnavailable."""
    ollama_host: str | None = None
    """Ollama server; None = ``$OLLAMA_HOST`` or http://localhost:11434."""
    n_threads: int = 1
    """Threads of the embedded model (more than one was slower on a busy 2-core host)."""
    replay_file: Path | None = None
    """For ``llm="replay"``: a replies JSON file or a scenario's ``trace.jsonl`` to re-run."""
    on_llm_error: Literal["raise", "fallback"] = "raise"
    """When the LLM is unavailable: stop (the worker retries later) or use the fallback."""
    sandbox: SandboxSettings = field(default_factory=batch_sandbox)
    replay: Any = None
    """``player.ReplaySettings``: validation plays each attempt in esmini (None: no replay)."""
    run_id: str | None = None
    """The run the calls belong to, logged with each (``scenweave logs --run``)."""

    def __post_init__(self) -> None:
        choices = (*backend_names(), "none")  # the built-in ones and the plugins'
        if self.llm not in choices:
            raise ValueError(f"llm: {self.llm!r} is not one of {', '.join(choices)}")
        if self.max_attempts < 1:
            raise ValueError("max_attempts: must be at least 1")
        self.repair = checked_repair(self.repair)

    @property
    def model_name(self) -> str:
        return self.model or DEFAULT_MODELS.get(self.llm, self.llm)  # a plugin's: its name

    @property
    def output_tokens(self) -> int:
        return self.max_tokens or DEFAULT_MAX_TOKENS.get(self.llm, DEFAULT_MAX_TOKENS["ollama"])

    @property
    def host(self) -> str:
        return self.ollama_host or os.environ.get("OLLAMA_HOST") or DEFAULT_OLLAMA_HOST

    def to_dict(self) -> dict:
        """A JSON-ready copy for ``run.json``."""
        data = asdict(self)
        data.update(model=self.model_name, max_tokens=self.output_tokens,
                    replay_file=str(self.replay_file) if self.replay_file else None)
        data["sandbox"] = {k: str(v) if isinstance(v, Path) else v
                           for k, v in data["sandbox"].items()}
        if self.llm == "ollama":
            data["ollama_host"] = self.host
        return data

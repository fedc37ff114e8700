"""An Ollama server through the official ``ollama`` client (SPEC §6): explicit options,
context window and timeout, the host from ``OLLAMA_HOST`` unless the settings name one."""

from __future__ import annotations

from typing import Any

import httpx
import ollama

from scenweave.agent.llm.base import LLM, LLMReply, LLMTimeout, LLMUnavailable, Prompt
from scenweave.agent.settings import AgentSettings


class OllamaLLM(LLM):
    """Chat completions from an Ollama server."""

    backend = "ollama"

    def __init__(self, settings: AgentSettings) -> None:
        super().__init__(settings.model_name)
        self.settings = settings
        self.host = settings.host
        self.client = ollama.Client(host=self.host, timeout=settings.timeout_s)

    def options(self) -> dict[str, Any]:
        """The sampling options sent with every call."""
        s = self.settings
        return {"temperature": s.temperature, "top_p": s.top_p, "num_predict": s.output_tokens,
                "num_ctx": s.num_ctx, "repeat_penalty": s.repeat_penalty}

    def check(self) -> None:
        """Raise :class:`LLMUnavailable` unless the server answers and has pulled the model."""
        listing = self._call(self.client.list)
        pulled = {m.model for m in listing.models}
        if self.model not in pulled and f"{self.model}:latest" not in pulled:
            raise LLMUnavailable(self._missing_model())

    def close(self) -> None:
        """Close the client's HTTP connections (the client keeps them alive between calls)."""
        inner = getattr(self.client, "_client", None)
        if inner is not None:
            inner.close()

    def _complete(self, prompt: Prompt) -> LLMReply:
        response = self._call(self.client.chat, self.model, messages=prompt.messages(),
                              options=self.options(), stream=False,
                              format=prompt.reply_schema)  # structured output when given
        meta = {key: getattr(response, key, None)
                for key in ("done_reason", "total_duration", "eval_duration")}
        return LLMReply(text=response.message.content or "",
                        tokens_in=response.prompt_eval_count or 0,
                        tokens_out=response.eval_count or 0,
                        model=response.model or self.model,
                        meta={k: v for k, v in meta.items() if v is not None})

    def _call(self, method: Any, *args: Any, **kwargs: Any) -> Any:
        try:
            return method(*args, **kwargs)
        except httpx.ConnectTimeout as err:  # nothing accepted the connection: unreachable
            raise LLMUnavailable(self._unreachable()) from err
        except httpx.TimeoutException as err:
            raise LLMTimeout(f"Ollama at {self.host} did not answer within "
                             f"{self.settings.timeout_s:g} s (AgentSettings.timeout_s / "
                             "--llm-timeout)") from err
        except (ConnectionError, httpx.TransportError) as err:
            raise LLMUnavailable(self._unreachable()) from err
        except ollama.ResponseError as err:
            if err.status_code == 404:
                raise LLMUnavailable(self._missing_model()) from err
            raise LLMUnavailable(f"Ollama at {self.host} failed: {err}") from err

    def _unreachable(self) -> str:
        return (f"cannot reach Ollama at {self.host}: start `ollama serve` or set OLLAMA_HOST"
                " / --ollama-host")

    def _missing_model(self) -> str:
        return (f"model '{self.model}' not found on Ollama at {self.host}: run "
                f"`ollama pull {self.model}` or choose --model")


def server_answers(host: str, timeout_s: float = 2.0) -> bool:
    """Whether an Ollama server answers at ``host`` (``--llm auto`` asks before a batch)."""
    url = host if "://" in host else f"http://{host}"
    try:
        return httpx.get(f"{url.rstrip('/')}/api/tags", timeout=timeout_s).is_success
    except httpx.HTTPError:
        return False

"""Recorded replies instead of a model: deterministic tests, and re-running a past trace.

``AgentSettings.replay_file`` is either
- a scenario's ``trace.jsonl``: the raw replies of its generate/repair events, in order;
- a JSON list of replies, used in order for every scenario; or
- a JSON object ``{scenario_id: [replies], "*": [replies for any other scenario]}``.
A reply is a string, or an object ``{"text": ..., "tokens_in": n, "tokens_out": n}``;
``{"raise": "timeout"}`` or ``{"raise": "unavailable"}`` makes that call fail as a real
backend would.
"""

from __future__ import annotations

import json
import threading
from collections import Counter
from pathlib import Path

from scenweave.agent.llm.base import LLM, LLMReply, LLMTimeout, LLMUnavailable, Prompt
from scenweave.agent.settings import AgentSettings

ANY = "*"


def load_replies(path: Path) -> dict[str, list]:
    """scenario id (or ``*``) -> its replies in order, from any of the supported files."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as err:
        raise LLMUnavailable(f"replay file {path}: {err} (--replay-file)") from err
    if Path(path).suffix == ".jsonl":
        return {ANY: _replies_from_trace(text, path)}
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise LLMUnavailable(f"replay file {path}: not JSON ({err})") from err
    if isinstance(data, list):
        return {ANY: data}
    if isinstance(data, dict) and all(isinstance(v, list) for v in data.values()):
        return data
    raise LLMUnavailable(f"replay file {path}: expected a list of replies or "
                         "{scenario_id: [replies]}")


def _replies_from_trace(text: str, path: Path) -> list:
    replies = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            event = json.loads(line)
        except json.JSONDecodeError as err:
            raise LLMUnavailable(f"replay file {path}, line {number}: not JSON ({err})") from err
        if event.get("node") in ("generate", "repair") and event.get("reply") is not None:
            replies.append({"text": event["reply"], "tokens_in": event.get("tokens_in", 0),
                            "tokens_out": event.get("tokens_out", 0)})
    return replies


class ReplayLLM(LLM):
    """Answers each scenario's n-th call with its n-th recorded reply."""

    backend = "replay"

    def __init__(self, settings: AgentSettings) -> None:
        super().__init__(settings.model_name)
        if settings.replay_file is None:
            raise LLMUnavailable("--llm replay needs --replay-file (AgentSettings.replay_file)")
        self.source = Path(settings.replay_file)
        self.replies = load_replies(self.source)
        self._calls: Counter[str] = Counter()
        self._lock = threading.Lock()

    def _complete(self, prompt: Prompt) -> LLMReply:
        key = prompt.scenario_id if prompt.scenario_id in self.replies else ANY
        with self._lock:
            index = self._calls[prompt.scenario_id]
            self._calls[prompt.scenario_id] += 1
        recorded = self.replies.get(key, [])
        if index >= len(recorded):
            raise LLMUnavailable(f"replay file {self.source}: no reply #{index + 1} recorded "
                                 f"for scenario {prompt.scenario_id!r} (record more replies)")
        return _as_reply(recorded[index])


def _as_reply(entry: str | dict) -> LLMReply:
    if isinstance(entry, str):
        return LLMReply(text=entry, tokens_in=0, tokens_out=len(entry.split()))
    failure = entry.get("raise")
    if failure == "timeout":
        raise LLMTimeout("replayed: the LLM did not answer in time (AgentSettings.timeout_s)")
    if failure:
        raise LLMUnavailable(f"replayed: the LLM was unavailable ({failure})")
    text = str(entry.get("text", ""))
    return LLMReply(text=text, tokens_in=int(entry.get("tokens_in", 0)),
                    tokens_out=int(entry.get("tokens_out", len(text.split()))))

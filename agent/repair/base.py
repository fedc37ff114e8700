"""What a repair strategy is: how the first script is asked for, and how a failure is repaired."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

from scenweave.agent.code import apply_corrections, extract_python_code
from scenweave.agent.llm.base import LLM, LLMReply, Prompt
from scenweave.agent.prompts import generation_prompt
from scenweave.agent.state import Attempt
from scenweave.schemas.params import Params


@dataclass
class Request:
    """What a strategy works from."""

    params: Params
    reference: str
    """Source of the retrieved reference script."""
    attempts: list[Attempt]
    """The attempts so far (empty for the first generation)."""
    values: dict | None = None
    """The record's values the script must have written in (None: params but metadata)."""

    @property
    def last(self) -> Attempt:
        return self.attempts[-1]

    def last_error_text(self) -> str:
        """The previous failure as the LLM should see it: traceback, or validation errors."""
        error = self.last.get("error") or {}
        return (error.get("traceback") or
                f"{error.get('type', 'Error')}: {error.get('message', '')}").strip()


@dataclass
class Candidate:
    """A script to try, with how it came about."""

    code: str
    prompt: Prompt | None = None
    reply: LLMReply | None = None
    extraction: dict = field(default_factory=dict)
    corrections: list[str] = field(default_factory=list)
    error: dict | None = None
    """Set when no runnable script could be made (e.g. an edit that does not apply)."""


class RepairStrategy(ABC):
    """A named way to get a working script. Subclasses override ``repair``, and may override
    ``generate`` (the first attempt; by default the thesis's whole-script prompt)."""

    name = ""
    description = ""

    def generate(self, request: Request, llm: LLM) -> Candidate:
        """The first attempt: thesis Table 5.5, whole script."""
        return ask_for_script(llm, generation_prompt(request.params, request.reference,
                                                     request.values))

    @abstractmethod
    def repair(self, request: Request, llm: LLM) -> Candidate:
        """A new candidate after ``request.last`` failed."""


def ask_for_script(llm: LLM, prompt: Prompt) -> Candidate:
    """Ask for a whole script; extract and correct the code of the reply."""
    reply = llm.complete(prompt)
    found = extract_python_code(reply.text)
    code, corrections = apply_corrections(found.code)
    return Candidate(code, prompt, reply, {"method": found.method, "warnings": found.warnings},
                     corrections)

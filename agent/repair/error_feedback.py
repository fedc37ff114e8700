"""The thesis's repair (Table 5.6): re-prompt with the previous code and its traceback, and
insist on reproducing the reference verbatim with only the numbers changed."""

from __future__ import annotations

from scenweave.agent.llm.base import LLM
from scenweave.agent.prompts import error_prompt
from scenweave.agent.repair.base import Candidate, RepairStrategy, Request, ask_for_script


class ErrorFeedback(RepairStrategy):
    name = "error_feedback"
    description = "re-prompt with the previous code and its error (thesis §5.3)"

    def repair(self, request: Request, llm: LLM) -> Candidate:
        prompt = error_prompt(request.params, request.reference, request.last.get("code", ""),
                              request.last_error_text(), request.values)
        return ask_for_script(llm, prompt)


STRATEGY = ErrorFeedback()

"""Ask for a small edit to the reference instead of the whole script.

The LLM answers with SEARCH/REPLACE blocks (or NO CHANGES), applied to the reference
script: far fewer output tokens than a whole script, and untouched lines cannot be garbled.
A block that does not apply fails the attempt with an error the next prompt shows.
"""

from __future__ import annotations

from scenweave.agent.code import PatchError, apply_corrections, apply_edit_blocks
from scenweave.agent.llm.base import LLM, Prompt
from scenweave.agent.prompts import patch_prompt
from scenweave.agent.repair.base import Candidate, RepairStrategy, Request


class Patch(RepairStrategy):
    name = "patch"
    description = "the LLM returns SEARCH/REPLACE edits to the reference script"

    def generate(self, request: Request, llm: LLM) -> Candidate:
        return self._ask(request, llm, patch_prompt(request.params, request.reference))

    def repair(self, request: Request, llm: LLM) -> Candidate:
        prompt = patch_prompt(request.params, request.reference, request.last_error_text())
        return self._ask(request, llm, prompt)

    def _ask(self, request: Request, llm: LLM, prompt: Prompt) -> Candidate:
        reply = llm.complete(prompt)
        try:
            code, edits = apply_edit_blocks(request.reference, reply.text)
        except PatchError as err:
            return Candidate("", prompt, reply, {"method": "edit_blocks", "warnings": []},
                             error={"type": "PatchError", "message": str(err)})
        code, corrections = apply_corrections(code)
        return Candidate(code, prompt, reply, {"method": "edit_blocks", "edits": edits,
                                               "warnings": []}, corrections)


STRATEGY = Patch()

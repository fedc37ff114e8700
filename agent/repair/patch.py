"""Ask for a small edit to the worked example instead of the whole script.

The LLM answers with JSON edits, one line each (``agent.edits``; the embedded model and
Ollama are held to their schema while decoding, so the reply parses and names real lines),
applied to the worked example: far fewer output tokens than a whole script, and untouched
lines cannot be garbled. An edit that does not apply fails the attempt with an error the next
prompt shows. Replies with SEARCH/REPLACE blocks (recorded before) are still applied.
"""

from __future__ import annotations

from scenweave.agent.code import PatchError, apply_corrections
from scenweave.agent.edits import apply_edits
from scenweave.agent.llm.base import LLM, Prompt
from scenweave.agent.prompts import patch_prompt
from scenweave.agent.repair.base import Candidate, RepairStrategy, Request


class Patch(RepairStrategy):
    name = "patch"
    description = "the LLM returns line edits (JSON) to the worked example"

    def generate(self, request: Request, llm: LLM) -> Candidate:
        prompt = patch_prompt(request.params, request.reference, values=request.values)
        return self._ask(request, llm, prompt)

    def repair(self, request: Request, llm: LLM) -> Candidate:
        prompt = patch_prompt(request.params, request.reference, request.last_error_text(),
                              request.values)
        return self._ask(request, llm, prompt)

    def _ask(self, request: Request, llm: LLM, prompt: Prompt) -> Candidate:
        reply = llm.complete(prompt)
        try:
            code, edits = apply_edits(request.reference, reply.text)
        except PatchError as err:
            return Candidate("", prompt, reply, {"method": "edit_blocks", "warnings": []},
                             error={"type": "PatchError", "message": str(err)})
        code, corrections = apply_corrections(code)
        return Candidate(code, prompt, reply, {"method": "edit_blocks", "edits": edits,
                                               "warnings": []}, corrections)


STRATEGY = Patch()

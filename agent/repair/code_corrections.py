"""Repair without asking the LLM when the error says what is wrong; else re-prompt.

Deterministic fixes keyed on the failure: a missing or wrong import or name gets the
reference's import block back; ``module has no attribute X`` becomes the closest real name
of that module; tabs and stray indentation are normalised. Only when none applies (or the
code would not change) is the LLM asked again, as in ``error_feedback``.
"""

from __future__ import annotations

import ast
import difflib
import importlib
import re
import textwrap

from agent.llm.base import LLM
from agent.repair.base import Candidate, RepairStrategy, Request
from agent.repair.error_feedback import ErrorFeedback

MISSING_MODULE_ATTR = re.compile(r"module '([\w.]+)' has no attribute '(\w+)'")
IMPORT_LINE = re.compile(r"^(?:from\s+\S+\s+import\s+|import\s+)")


def reference_imports(reference: str) -> str:
    """The reference script's top-level import statements, verbatim."""
    tree = ast.parse(reference)
    lines = reference.splitlines(keepends=True)
    return "".join("".join(lines[node.lineno - 1:node.end_lineno]) for node in tree.body
                   if isinstance(node, ast.Import | ast.ImportFrom))


def restore_imports(code: str, reference: str) -> str:
    """``code`` with its top-level imports replaced by the reference's."""
    kept, skipping = [], False
    for line in code.splitlines(keepends=True):
        if skipping:
            skipping = ")" not in line
            continue
        if IMPORT_LINE.match(line):
            skipping = "(" in line and ")" not in line
            continue
        kept.append(line)
    body = "".join(kept)
    docstring = re.match(r'\s*(""".*?"""|\'\'\'.*?\'\'\')\s*\n', body, re.S)
    head = docstring.group(0) if docstring else ""
    return head + "\n" + reference_imports(reference) + "\n" + body[len(head):].lstrip("\n")


def closest_attribute(module_name: str, wrong: str) -> str | None:
    """The attribute of ``module_name`` most like ``wrong`` (None if nothing is close)."""
    try:
        module = importlib.import_module(module_name)
    except ImportError:
        return None
    names = [n for n in dir(module) if not n.startswith("_")]
    close = difflib.get_close_matches(wrong, names, n=1, cutoff=0.6)
    return close[0] if close else None


def fix_attribute(code: str, message: str) -> str:
    match = MISSING_MODULE_ATTR.search(message)
    if not match:
        return code
    module_name, wrong = match.groups()
    right = closest_attribute(module_name, wrong)
    if right is None:
        return code
    alias = module_name.rsplit(".", 1)[-1]
    return re.sub(rf"\b{re.escape(alias)}\.{re.escape(wrong)}\b", f"{alias}.{right}", code)


def fix_indentation(code: str) -> str:
    return textwrap.dedent(code.expandtabs(4))


def deterministic_fix(code: str, error_type: str, message: str, reference: str) -> tuple[str, str]:
    """The fixed code and the fix's name, or ``code`` unchanged and ''."""
    if error_type in ("ImportError", "ModuleNotFoundError", "NameError"):
        return restore_imports(code, reference), "restore_imports"
    if error_type == "AttributeError":
        return fix_attribute(code, message), "closest_attribute"
    if error_type in ("IndentationError", "TabError"):
        return fix_indentation(code), "normalise_indentation"
    return code, ""


class CodeCorrections(RepairStrategy):
    name = "code_corrections"
    description = "deterministic fixes from the error; the LLM only when none applies"

    def repair(self, request: Request, llm: LLM) -> Candidate:
        last = request.last
        error = last.get("error") or {}
        code = last.get("code") or ""
        fixed, fix = deterministic_fix(code, error.get("type", ""), error.get("message", ""),
                                       request.reference)
        if code and fix and fixed != code:
            return Candidate(fixed, extraction={"method": "deterministic", "warnings": []},
                             corrections=[fix])
        return ErrorFeedback().repair(request, llm)


STRATEGY = CodeCorrections()

"""Repair without asking the LLM when the error says what is wrong; else re-prompt.

Deterministic fixes keyed on the failure: a missing or wrong import or name gets the
reference's import block back; ``module has no attribute X`` and ``type object C has no
attribute X`` become the closest real name of that module or class (only the modules the
reference imports and ``scenariogeneration`` are ever looked into); tabs and stray
indentation are normalised. Only when none applies (or the code would not change) is the
LLM asked again, as in ``error_feedback``.
"""

from __future__ import annotations

import ast
import difflib
import importlib
import re
import sys
import textwrap
from types import ModuleType

from scenweave.agent.llm.base import LLM
from scenweave.agent.repair.base import Candidate, RepairStrategy, Request
from scenweave.agent.repair.error_feedback import ErrorFeedback

MISSING_MODULE_ATTR = re.compile(r"module '([\w.]+)' has no attribute '(\w+)'")
MISSING_CLASS_ATTR = re.compile(r"type object '(\w+)' has no attribute '(\w+)'")
#: modules a fix may import besides the reference's own imports (see ``allowed_modules``)
ALLOWED_ROOTS = ("scenariogeneration",)
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


def allowed_modules(reference: str) -> tuple[str, ...]:
    """The modules whose attributes a fix may look up: ``scenariogeneration`` and what the
    reference script imports. The error message naming a module comes from code the LLM
    wrote, so nothing else is ever imported on its say-so."""
    tree = ast.parse(reference)
    names = {alias.name for node in tree.body if isinstance(node, ast.Import)
             for alias in node.names}
    names |= {node.module for node in tree.body
              if isinstance(node, ast.ImportFrom) and node.module and not node.level}
    return tuple(sorted(names | set(ALLOWED_ROOTS)))


def is_allowed(module_name: str, allowed: tuple[str, ...]) -> bool:
    """True for a module of the allow-list or a submodule of one."""
    return any(module_name == root or module_name.startswith(root + ".") for root in allowed)


def allowed_module(module_name: str, allowed: tuple[str, ...]) -> ModuleType | None:
    """The module, imported only if it is on the allow-list (None otherwise or if missing)."""
    if not is_allowed(module_name, allowed):
        return None
    try:
        return importlib.import_module(module_name)
    except (ImportError, ValueError):
        return None


def find_class(name: str, allowed: tuple[str, ...]) -> type | None:
    """A class called ``name`` defined in or exported by an allowed, loaded module."""
    for root in allowed:
        allowed_module(root, allowed)
    for module_name, module in sorted(sys.modules.items()):
        if module is not None and is_allowed(module_name, allowed):
            found = vars(module).get(name)
            if isinstance(found, type):
                return found
    return None


def closest_attribute(owner: object, wrong: str, then: str | None = None) -> str | None:
    """The public attribute of ``owner`` most like ``wrong`` (None if nothing is close).

    ``then`` is the attribute the code reads next (``xosc.ManeuverPriority.overwrite``:
    ``overwrite``); of the close names, one that has it wins (``Priority``).
    """
    names = [n for n in dir(owner) if not n.startswith("_")]
    close = difflib.get_close_matches(wrong, names, n=5, cutoff=0.6)
    fitting = [n for n in close if then and hasattr(getattr(owner, n, None), then)]
    found = fitting or close
    return found[0] if found else None


def fix_attribute(code: str, message: str, allowed: tuple[str, ...]) -> str:
    """``owner.wrong`` replaced by the closest real attribute, for ``module 'm' has no
    attribute`` (owner: the module's last name, e.g. ``xosc``) and ``type object 'C' has no
    attribute`` (owner: the class, looked up in the allowed modules)."""
    owner: ModuleType | type | None
    if match := MISSING_MODULE_ATTR.search(message):
        module_name, wrong = match.groups()
        owner, prefix = allowed_module(module_name, allowed), module_name.rsplit(".", 1)[-1]
    elif match := MISSING_CLASS_ATTR.search(message):
        prefix, wrong = match.groups()
        owner = find_class(prefix, allowed)
    else:
        return code
    if owner is None:
        return code
    used = rf"\b{re.escape(prefix)}\.{re.escape(wrong)}\b"
    then = re.search(used + r"\.(\w+)", code)
    right = closest_attribute(owner, wrong, then.group(1) if then else None)
    return code if right is None else re.sub(used, f"{prefix}.{right}", code)


def fix_indentation(code: str) -> str:
    return textwrap.dedent(code.expandtabs(4))


def deterministic_fix(code: str, error_type: str, message: str, reference: str) -> tuple[str, str]:
    """The fixed code and the fix's name, or ``code`` unchanged and ''."""
    if error_type in ("ImportError", "ModuleNotFoundError", "NameError"):
        return restore_imports(code, reference), "restore_imports"
    if error_type == "AttributeError":
        return fix_attribute(code, message, allowed_modules(reference)), "closest_attribute"
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

"""Edits the model cannot get wrong in form: the ``patch`` strategy's structured replies.

The reply is JSON, ``{"edits": [{"search": LINE, "replace": TEXT}, ...]}``, where LINE is one
line of the worked example that occurs there exactly once. :func:`edit_schema` is that as a
JSON schema (``search`` an ``enum`` of those lines) for Ollama's structured output,
:func:`edit_grammar` the same as a llama.cpp GBNF grammar for the embedded model (written
here: llama-cpp-python's own schema converter escapes quotes in enum strings wrongly, and
orders ``replace`` before ``search``). Decoding is held to them token by token, so the reply
always parses and every search line exists. Older replies
in the SEARCH/REPLACE block format are still applied (``agent.code.apply_edit_blocks``).
"""

from __future__ import annotations

import json
from collections import Counter

from scenweave.agent.code import (
    SPECIAL_TOKENS,
    THINK_BLOCK,
    PatchError,
    apply_edit_blocks,
)

EDIT_START = '{"search"'


def searchable_lines(reference: str) -> list[str]:
    """The lines of ``reference`` an edit may name: non-blank, and each there exactly once."""
    counts = Counter(reference.splitlines())
    return [line for line in reference.splitlines() if line.strip() and counts[line] == 1]


def edit_schema(reference: str) -> dict:
    """The JSON schema of an edit reply against ``reference`` (see the module docstring)."""
    lines = searchable_lines(reference)
    edit = {"type": "object",
            "properties": {"search": {"enum": lines}, "replace": {"type": "string"}},
            "required": ["search", "replace"]}
    return {"type": "object",
            "properties": {"edits": {"type": "array", "items": edit, "maxItems": len(lines)}},
            "required": ["edits"]}


def edit_grammar(reference: str) -> str:
    """The GBNF grammar of an edit reply against ``reference``: ``search`` before
    ``replace``, ``search`` one of :func:`searchable_lines`, ``replace`` one JSON string."""
    lines = " | ".join(_gbnf_literal(json.dumps(line)) for line in searchable_lines(reference))
    return "\n".join((
        'root ::= "{" ws "\\"edits\\":" ws "[" ws (edit ("," ws edit)*)? ws "]" ws "}"',
        'edit ::= "{" ws "\\"search\\":" ws line "," ws "\\"replace\\":" ws string ws "}"',
        f"line ::= {lines}",
        'string ::= "\\"" char* "\\""',
        'char ::= [^"\\\\\\x00-\\x1f] | "\\\\" (["\\\\/bfnrt] | "u" hex hex hex hex)',
        "hex ::= [0-9a-fA-F]",
        'ws ::= [ \\t\\n]{0,4}',
    )) + "\n"


def _gbnf_literal(text: str) -> str:
    """``text`` as a GBNF string literal."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def apply_edits(reference: str, reply: str) -> tuple[str, int]:
    """``reference`` with the reply's edits applied, and how many; JSON edits or, for replies
    that are not JSON, SEARCH/REPLACE blocks. PatchError says which edit does not apply."""
    text = THINK_BLOCK.sub("", SPECIAL_TOKENS.sub("", reply or "")).strip()
    if not text.startswith("{"):
        return apply_edit_blocks(reference, text)
    edits = parse_edits(text)
    lines = reference.splitlines(keepends=True)
    edited: dict[str, int] = {}
    for number, edit in enumerate(edits, start=1):
        if edit["search"] in edited:
            raise PatchError(f"edit {number}: edit {edited[edit['search']]} already changed "
                             f"that line ({edit['search'][:80]!r}); one edit per line")
        edited[edit["search"]] = number
        index = _line_index(lines, edit, number)
        lines[index] = _indented(edit["replace"], edit["search"]) + "\n"
    return "".join(lines), len(edits)


def parse_edits(text: str) -> list[dict]:
    """The edits of a JSON reply; of one cut short (the output cap), every complete edit."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        return _complete_edits(text)
    edits = data.get("edits") if isinstance(data, dict) else None
    if not isinstance(edits, list):
        raise PatchError('the reply is JSON but has no "edits" list')
    return [_checked(edit, number) for number, edit in enumerate(edits, start=1)]


def _complete_edits(text: str) -> list[dict]:
    decoder, edits, at = json.JSONDecoder(), [], text.find(EDIT_START)
    while at != -1:
        try:
            edit, end = decoder.raw_decode(text, at)
        except json.JSONDecodeError:
            break
        edits.append(_checked(edit, len(edits) + 1))
        at = text.find(EDIT_START, end)
    if not edits and EDIT_START not in text and '"edits"' not in text:
        raise PatchError("the reply is neither JSON edits nor SEARCH/REPLACE blocks")
    return edits


def _checked(edit: object, number: int) -> dict:
    if not (isinstance(edit, dict) and isinstance(edit.get("search"), str)
            and isinstance(edit.get("replace"), str)):
        raise PatchError(f'edit {number}: expected {{"search": LINE, "replace": TEXT}}')
    return edit


def _line_index(lines: list[str], edit: dict, number: int) -> int:
    hits = [i for i, line in enumerate(lines) if line.rstrip("\n") == edit["search"]]
    if len(hits) != 1:
        where = "not a line of" if not hits else f"{len(hits)} lines of"
        raise PatchError(f"edit {number}: the search line is {where} the script "
                         f"({edit['search'][:80]!r})")
    return hits[0]


def _indented(replace: str, search: str) -> str:
    """``replace`` with ``search``'s indentation when the model left its own out."""
    indent = search[:len(search) - len(search.lstrip())]
    if replace.startswith((" ", "\t")) or not indent:
        return replace.rstrip("\n")
    return indent + replace.rstrip("\n")

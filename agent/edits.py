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

import io
import json
import keyword as keyword_module
import re
import tokenize
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


def value_edit_grammar(reference: str, new_keys: tuple[str, ...] = (),
                       min_edits: int = 0) -> str:
    """The GBNF grammar of an edit reply that can change only values: ``search`` one of the
    lines of ``reference`` holding a literal (each there once), ``replace`` that line with
    only its literals free, each to a value of its type (numbers, strings but dict keys,
    ``True``/``False``; ``None`` to anything); after
    a ``"key": value,`` line of a dict, new ``"key": value,`` lines for ``new_keys`` may
    follow; at least ``min_edits`` edits (one per value to change: a small model otherwise
    stops after the first) and at most :data:`SPARE_EDITS` more, numbers and strings of
    bounded length (a small model otherwise repeats an edit or a digit until its output
    tokens run out, and the cut reply is no JSON). A reply in it cannot break the script's
    syntax, rename a key or touch code; a script with no such line gets :func:`edit_grammar`."""
    slots = _literal_slots(reference)
    counts = Counter(reference.splitlines())
    pairs = [_pair_rule(line, slots[number], new_keys)
             for number, line in enumerate(reference.splitlines(), start=1)
             if slots.get(number) and counts[line] == 1]
    if not pairs:
        return edit_grammar(reference)
    most = max(min(len(pairs), min_edits + SPARE_EDITS), min_edits, 1)
    edits = (f'(edit ("," ws edit){{0,{most - 1}}})?' if min_edits < 1 else
             f'edit ("," ws edit){{{min_edits - 1},{most - 1}}}')
    rules = [
        f'root ::= "{{" ws "\\"edits\\":" ws "[" ws {edits} ws "]" ws "}}"',
        'edit ::= "{" ws "\\"search\\":" ws pair ws "}"',
        "pair ::= " + " | ".join(pairs),
        'val ::= num | pystr | bool | "None"',
        'bool ::= "True" | "False"',
        *PHASE_RULES,
        'num ::= "-"? [0-9]{1,17} ("." [0-9]{1,17})? ([eE] [-+]? [0-9]{1,3})?',
        f"pystr ::= {_gbnf_literal(QUOTE)} [a-zA-Z0-9_ ./:-]{{0,80}} {_gbnf_literal(QUOTE)}",
        'ws ::= [ \\t\\n]{0,4}',
    ]
    if new_keys:
        options = [f"({' | '.join(_gbnf_literal(key) for key in keys)}) "
                   f"{_gbnf_literal(_json_inner(chr(34) + ': '))} {value} {_gbnf_literal(',')}"
                   for keys, value in ((_plain(new_keys), "val"),
                                       (_phase_keys(new_keys), "phases")) if keys]
        entry = _gbnf_literal(_json_inner(chr(10) + "    " + chr(34)))
        rules.append(f"added ::= {entry} ({' | '.join(options)})")
    return "\n".join(rules) + "\n"


#: edits a value-only reply may make beyond one per value to change
SPARE_EDITS = 3
#: a speed profile (``scenario_lib.phases``) as the worked example writes it: a list of phases,
#: each ``{'start_s': N, 'duration_s': N, 'target_ms': N, 'shape': S}``; up to 32 of them
PHASE_RULES = (
    'phases ::= "[" (phase (", " phase){0,31})? "]"',
    "phase ::= \"{'start_s': \" num \", 'duration_s': \" num \", 'target_ms': \" num "
    "\", 'shape': \" shape \"}\"",
    "shape ::= \"'linear'\" | \"'cubic'\" | \"'sinusoidal'\" | \"'step'\"",
)
#: a ``RECORD`` entry holding a speed profile: its phases may change in number, not only value
PHASE_ENTRY = re.compile(r'^(\s+"\w+_phases": )\[.*\],$')


def _phase_keys(keys: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(key for key in keys if key.endswith("_phases"))


def _plain(keys: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(key for key in keys if not key.endswith("_phases"))


#: a double quote as it stands inside a JSON string
QUOTE = '\\"'
#: a ``"key": value,`` entry of a dict literal, alone on its line
DICT_ENTRY = re.compile(r'^\s+"\w+": .*,$')


def _pair_rule(line: str, slots: list[tuple[int, int]], new_keys: tuple[str, ...]) -> str:
    """``SEARCH "," ws "replace": REPLACE`` for one line: the line, then its template (a
    speed profile's line: its key, then any list of phases)."""
    profile = PHASE_ENTRY.match(line)
    if profile:
        return (f'({_gbnf_literal(json.dumps(line))} "," ws "\\"replace\\":" ws '
                f'"\\"" {_gbnf_literal(_json_inner(profile.group(1)))} phases '
                f'{_gbnf_literal(",")} "\\"")')
    pieces, at = [], 0
    for start, end in slots:
        pieces.append(_gbnf_literal(_json_inner(line[at:start])) if start > at else "")
        pieces.append(_slot_rule(line[start:end]))
        at = end
    pieces.append(_gbnf_literal(_json_inner(line[at:])) if at < len(line) else "")
    added = " added*" if new_keys and DICT_ENTRY.match(line) else ""
    template = " ".join(piece for piece in pieces if piece)
    return (f'({_gbnf_literal(json.dumps(line))} "," ws "\\"replace\\":" ws '
            f'"\\"" {template}{added} "\\"")')


def _slot_rule(literal: str) -> str:
    """What may stand where ``literal`` stands: a value of its type (``None``: any)."""
    if literal.startswith('"'):
        return "pystr"
    if literal in ("True", "False"):
        return "bool"
    return "val" if literal == "None" else "num"


def _json_inner(text: str) -> str:
    """``text`` as it stands between the quotes of a JSON string."""
    return json.dumps(text)[1:-1]


def _literal_slots(reference: str) -> dict[int, list[tuple[int, int]]]:
    """Line number -> the column spans of the literals a value edit may change: numbers
    (with a unary minus), ``True``/``False``/``None``, and one-line strings in an expression
    that are no dict key (a docstring or a string statement is not one)."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(reference).readline))
    except (tokenize.TokenError, SyntaxError):
        return {}
    slots: dict[int, list[tuple[int, int]]] = {}
    for index, token in enumerate(tokens):
        before = tokens[index - 1] if index else None
        after = tokens[index + 1] if index + 1 < len(tokens) else None
        keyword = token.type == tokenize.NAME and token.string in ("True", "False", "None")
        value_string = (token.type == tokenize.STRING and token.start[0] == token.end[0]
                        and not (after is not None and after.string == ":")
                        and before is not None and (before.type == tokenize.OP
                                                    or keyword_module.iskeyword(before.string)))
        if not (token.type == tokenize.NUMBER or keyword or value_string):
            continue
        start = token.start[1]
        if (token.type == tokenize.NUMBER and before is not None and before.string == "-"
                and index > 1 and tokens[index - 2].type == tokenize.OP
                and tokens[index - 2].string in "([{,:=" and before.end == token.start):
            start = before.start[1]
        slots.setdefault(token.start[0], []).append((start, token.end[1]))
    return slots


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
    original = reference.splitlines(keepends=True)
    lines = list(original)
    for number, edit in enumerate(edits, start=1):
        index = _line_index(original, edit, number)  # a line edited twice: the last edit wins
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
    decoder, at = json.JSONDecoder(), text.find(EDIT_START)
    edits: list[dict] = []
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

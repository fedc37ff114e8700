"""``--where``: which records a user wants, as a small expression over a record's fields
(``scenweave mine --where`` and ``scenweave run --where``; docs/mining.md, "Choosing records").

The language, read by our own tokenizer and recursive-descent parser (user text is never
evaluated as Python)::

    expression := disjunct ("or" disjunct)*
    disjunct   := term ("and" term)*
    term       := "not" term | "(" expression ")" | comparison
    comparison := FIELD ("<" | "<=" | ">" | ">=" | "==" | "!=") VALUE
                | FIELD ["not"] "in" "(" VALUE ("," VALUE)* ")"
    VALUE      := a number (2, -0.5, 1e3) | a bare word (CINF, true) | a quoted string

Keywords are case-insensitive; field names and text values are not. A field the record does
not have (``ttc_min_s`` of a free ride that never closes in) makes its comparison false,
``not in`` included; ``not (...)`` of such a comparison is true. A malformed expression or an
unknown field is a :class:`WhereError` naming the column (1-based) and what was expected.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenweave import maneuvers
from scenweave.errors import InputError
from scenweave.mining.criticality import CRITICALITY_FIELDS, criticality

#: a record -> True when it is wanted
Predicate = Callable[[Mapping[str, Any]], bool]
Value = float | str | bool

#: the comparison operators, longest first so "<=" is not read as "<"
OPERATORS = ("<=", ">=", "==", "!=", "<", ">")
KEYWORDS = ("and", "or", "not", "in")
_TOKEN = re.compile(r"""
    (?P<space>\s+)
  | (?P<number>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.]))
  | (?P<word>[A-Za-z_][\w.\-]*)
  | (?P<string>"(?:[^"\\]|\\.)*"|'(?:[^'\\]|\\.)*')
  | (?P<op><=|>=|==|!=|<|>)
  | (?P<punct>[(),])
""", re.VERBOSE)


class WhereError(InputError, ValueError):
    """A ``--where`` expression that cannot be read: its one line names the column."""


class NothingMatched(InputError, LookupError):
    """``--where`` matched none of the records: nothing is made (exit 1, not a usage error:
    the expression was fine, the data holds no such event)."""

    def __init__(self, text: str, looked_at: int) -> None:
        super().__init__(f"--where {text!r} matched none of the {looked_at} records: nothing "
                         "written")


@dataclass(frozen=True)
class Token:
    kind: str  # number, word, string, op, punct, keyword, end
    text: str
    column: int  # 1-based


def tokenize(text: str) -> list[Token]:
    """The expression's tokens, ending with an ``end`` token; an unknown character is an
    error at its column."""
    tokens, at = [], 0
    while at < len(text):
        match = _TOKEN.match(text, at)
        if match is None:
            hint = " (equality is ==)" if text[at] == "=" else ""
            raise WhereError(f"column {at + 1}: unexpected character {text[at]!r} (expected a "
                             f"field, a value, an operator, a parenthesis or a comma){hint}")
        kind = match.lastgroup or ""
        if kind != "space":
            word = match.group()
            if kind == "word" and word.lower() in KEYWORDS:
                kind, word = "keyword", word.lower()
            tokens.append(Token(kind, word, at + 1))
        at = match.end()
    tokens.append(Token("end", "", len(text) + 1))
    return tokens


# --- the fields a record offers ---------------------------------------------------------------

def _provenance(record: Mapping[str, Any]) -> Mapping[str, Any]:
    found = record.get("provenance")
    return found if isinstance(found, Mapping) else {}


def _track(role: str) -> Callable[[Mapping[str, Any]], Any]:
    return lambda r: (_provenance(r).get("tracks") or {}).get(role)


def _file(record: Mapping[str, Any]) -> Any:
    name = _provenance(record).get("file") or (record.get("source") or {}).get("file")
    return Path(str(name)).name if name else None


def _duration(record: Mapping[str, Any]) -> Any:
    where = _provenance(record)
    start, end = where.get("start_s"), where.get("end_s")
    return end - start if isinstance(start, int | float) and isinstance(end, int | float) \
        else None


def criticality_of(record: Mapping[str, Any]) -> Mapping[str, Any]:
    """The record's ``criticality`` as written by ``scenweave mine``; a mined record written
    before it existed has it measured from its series now; a record without either has none."""
    found = record.get("criticality")
    if isinstance(found, Mapping):
        return found
    series = record.get("series")
    return criticality(series) if isinstance(series, Mapping) else {}


def _top(name: str) -> Callable[[Mapping[str, Any]], Any]:
    return lambda r: r.get(name)


def _critical(name: str) -> Callable[[Mapping[str, Any]], Any]:
    return lambda r: criticality_of(r).get(name)


#: field -> how to read it from a record; the params' fields (every registered class's
#: layout fields) are read from ``params``
RECORD_FIELDS: dict[str, Callable[[Mapping[str, Any]], Any]] = {
    **{name: _critical(name) for name in CRITICALITY_FIELDS},
    **{name: _top(name) for name in ("maneuver_class", "maneuver_tag", "domain", "scenario_id",
                                     "has_npc", "npc_position", "behavior_type")},
    "file": _file, "ego": _track("ego"), "npc": _track("npc"),
    "start_s": lambda r: _provenance(r).get("start_s"),
    "end_s": lambda r: _provenance(r).get("end_s"), "duration_s": _duration,
}


def known_fields() -> list[str]:
    """Every field an expression may name: the record's own and its classes' params."""
    params = {f for code in maneuvers.codes() for f in maneuvers.get(code).layout_fields}
    return [*RECORD_FIELDS, *sorted(params - set(RECORD_FIELDS))]


def field_value(record: Mapping[str, Any], name: str) -> Any:
    """``name`` of ``record`` (None where the record has no such value)."""
    if name in RECORD_FIELDS:
        return RECORD_FIELDS[name](record)
    params = record.get("params")
    return params.get(name) if isinstance(params, Mapping) else None


# --- the parser -------------------------------------------------------------------------------

class _Parser:
    """Recursive descent over the tokens, one method per rule of the grammar."""

    def __init__(self, text: str) -> None:
        self.tokens = tokenize(text)
        self.at = 0
        self.fields = known_fields()

    def parse(self) -> Predicate:
        if self.peek().kind == "end":
            self.fail("a comparison such as ttc_min_s < 2")
        found = self.expression()
        if self.peek().kind != "end":
            self.fail("'and', 'or' or the end of the expression")
        return found

    def peek(self) -> Token:
        return self.tokens[self.at]

    def take(self) -> Token:
        token = self.tokens[self.at]
        self.at += 1
        return token

    def fail(self, expected: str) -> None:
        token = self.peek()
        found = "the end of the expression" if token.kind == "end" else repr(token.text)
        raise WhereError(f"column {token.column}: expected {expected}, found {found}")

    def accept(self, kind: str, text: str) -> bool:
        if self.peek().kind == kind and self.peek().text == text:
            self.at += 1
            return True
        return False

    def expression(self) -> Predicate:
        parts = [self.disjunct()]
        while self.accept("keyword", "or"):
            parts.append(self.disjunct())
        return parts[0] if len(parts) == 1 else (lambda r: any(p(r) for p in parts))

    def disjunct(self) -> Predicate:
        parts = [self.term()]
        while self.accept("keyword", "and"):
            parts.append(self.term())
        return parts[0] if len(parts) == 1 else (lambda r: all(p(r) for p in parts))

    def term(self) -> Predicate:
        if self.accept("keyword", "not"):
            inner = self.term()
            return lambda r: not inner(r)
        if self.accept("punct", "("):
            inner = self.expression()
            if not self.accept("punct", ")"):
                self.fail("')' or 'and'/'or'")
            return inner
        return self.comparison()

    def comparison(self) -> Predicate:
        token = self.peek()
        if token.kind != "word":
            self.fail("a field name, 'not' or '('")
        if token.text not in self.fields:
            raise WhereError(f"column {token.column}: unknown field {token.text!r}; known: "
                             + ", ".join(self.fields))
        name = self.take().text
        if self.peek().kind == "op":
            op = self.take().text
            return _compare(name, op, self.value())
        negated = self.accept("keyword", "not")
        if not self.accept("keyword", "in"):
            self.fail("'in'" if negated else "a comparison (< <= > >= == !=), 'in' or 'not in'")
        choices = self.choices()
        return _member(name, choices, negated)

    def choices(self) -> list[Value]:
        if not self.accept("punct", "("):
            self.fail("'(' opening the list of values")
        found = [self.value()]
        while self.accept("punct", ","):
            found.append(self.value())
        if not self.accept("punct", ")"):
            self.fail("',' or ')'")
        return found

    def value(self) -> Value:
        token = self.peek()
        if token.kind == "number":
            self.take()
            return float(token.text)
        if token.kind == "string":
            self.take()
            return re.sub(r"\\(.)", r"\1", token.text[1:-1])
        if token.kind in ("word", "keyword"):
            self.take()
            lowered = token.text.lower()
            return {"true": True, "false": False}.get(lowered, token.text)
        self.fail("a value (a number, a word or a quoted string)")
        raise AssertionError  # fail raised


def _matches(value: Any, op: str, wanted: Value) -> bool:
    """``value op wanted``; a missing value, or kinds that do not compare, is False."""
    if value is None or isinstance(value, Mapping | list):
        return False
    if isinstance(wanted, bool) or isinstance(value, bool):
        same = bool(value) is wanted if isinstance(wanted, bool) and isinstance(value, bool) \
            else False
        return {"==": same, "!=": not same}.get(op, False)
    if isinstance(wanted, float) and isinstance(value, str):
        value = _number(value)  # a track id as text ("400") against 400
    if isinstance(wanted, float) != isinstance(value, int | float):
        return op == "!="  # a number against text: unequal, and in no order
    ordered = {"<": value < wanted, "<=": value <= wanted, ">": value > wanted,
               ">=": value >= wanted, "==": value == wanted, "!=": value != wanted}
    return bool(ordered[op])


def _number(text: str) -> float | str:
    """``text`` as a number when it is one, else itself."""
    try:
        return float(text)
    except ValueError:
        return text


def _compare(name: str, op: str, wanted: Value) -> Predicate:
    return lambda record: _matches(field_value(record, name), op, wanted)


def _member(name: str, choices: list[Value], negated: bool) -> Predicate:
    def test(record: Mapping[str, Any]) -> bool:
        value = field_value(record, name)
        if value is None:
            return False
        found = any(_matches(value, "==", choice) for choice in choices)
        return not found if negated else found
    return test


@dataclass(frozen=True)
class Where:
    """A parsed ``--where``: its text (for reports) and the test it describes."""

    text: str
    test: Predicate

    def __call__(self, record: Mapping[str, Any]) -> bool:
        return self.test(record)


def parse_where(text: str) -> Where:
    """The record test ``text`` describes; a :class:`WhereError` naming the column where it
    cannot be read, or the unknown field and the known ones."""
    return Where(text, _Parser(text).parse())

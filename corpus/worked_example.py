"""A reference script as a worked example: the script with one record's values written in.

The reference scripts read every value from ``params``. What the LLM adapts is their worked
example (SPEC §12): the same script where each ``params[...]`` read is the example's literal
value and the building blocks that take the whole mapping get ``record``, the example's
values as a dict literal (``RECORD``). The LLM's job is to write the record's values in their
place; the script it writes is run with :data:`PROVENANCE_KEYS` only, so a value it did not
write in is missing, and parameter fidelity and the replay catch every one it got wrong.

The examples are data (``worked_examples.json``, one params dict per script: thesis
Appendix B.3's BR_BK row for the brake script, a seeded sample record for the others, each
with its Town04 spawn; remade by ``scripts/make_worked_examples.py``). The worked example is
derived from the script mechanically (``ast``), never written by hand.
"""

from __future__ import annotations

import ast
import json
import tempfile
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

from scenweave import maneuvers
from scenweave.corpus.retrieval import CORPUS_DIR, _load_script, script_path
from scenweave.schemas.scenario_folder import XOSC_NAME

EXAMPLES_FILE = CORPUS_DIR / "worked_examples.json"
#: the only params an adapted script is given: where the record came from, never a value the
#: scenario plays (``scenario_id`` names the file header)
PROVENANCE_KEYS = ("scenario_id",)
RECORD_NAME = "RECORD"
LOCAL_NAME = "record"
PARAMS_NAME = "params"


@cache
def _examples() -> dict[str, dict]:
    return json.loads(EXAMPLES_FILE.read_text(encoding="utf-8"))


def example_params(script: Path) -> dict | None:
    """The example params the reference script ``script`` was written for: the corpus's
    stored example, or the one a plugin class brings (``Maneuver.example``); None if none."""
    found: Mapping[str, Any] | None = (_examples().get(Path(script).name)
                                       if Path(script).parent == CORPUS_DIR else None)
    if found is None:
        found = next((m.example for m in maneuvers.maneuvers() if m.example is not None
                      and script_path(m) == Path(script)), None)
    return dict(found) if found is not None else None


def provenance(params: Mapping[str, Any]) -> dict:
    """What a sandboxed, adapted script receives as ``params``: the provenance keys only."""
    return {key: params[key] for key in PROVENANCE_KEYS if key in params}


class _Recording(dict):
    """A params dict that remembers which keys were read (``[]``, ``get``, ``in``)."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.read: list[str] = []

    def _note(self, key: Any) -> None:
        if isinstance(key, str) and key not in self.read:
            self.read.append(key)

    def __getitem__(self, key: Any) -> Any:
        self._note(key)
        return super().__getitem__(key)

    def get(self, key: Any, default: Any = None) -> Any:
        self._note(key)
        return super().get(key, default)

    def __contains__(self, key: object) -> bool:
        self._note(key)
        return super().__contains__(key)


def keys_read(script: Path, params: Mapping[str, Any]) -> list[str]:
    """The params keys the reference ``script`` reads when it makes ``params``'s scenario."""
    recording = _Recording(params)
    with tempfile.TemporaryDirectory(prefix="scenweave-example-") as tmp:
        _load_script(Path(script)).generate(recording, str(Path(tmp) / XOSC_NAME))
    return [key for key in recording.read if key in params]


def record_values(script: Path, params: Mapping[str, Any]) -> dict:
    """The values of ``params`` the script plays: every key it reads but provenance."""
    return {key: params[key] for key in keys_read(script, params)
            if key not in PROVENANCE_KEYS}


def worked_example(script: Path, params: Mapping[str, Any]) -> str:
    """``script``'s source with ``params``'s values written in (see the module docstring)."""
    source = Path(script).read_text(encoding="utf-8")
    return write_values_in(source, record_values(script, params))


def adaptation(script: Path, params: Mapping[str, Any]) -> tuple[str, dict]:
    """What the LLM is given for ``params``'s record: ``script``'s worked example and the
    record's values to write into it. A script without a stored example (a plugin class's)
    is its own example, written out with the record's values."""
    example = example_params(script)
    try:
        values = record_values(script, params)
    except Exception:  # noqa: BLE001 - params the reference cannot use: the fallback says why
        values = {k: v for k, v in params.items() if k not in PROVENANCE_KEYS}
    return worked_example(script, params if example is None else example), values


def written_values(source: str) -> dict | None:
    """The values a worked example has written into its ``RECORD`` (None: it has none, or
    it is not Python)."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return None
    for node in tree.body:
        if (isinstance(node, ast.Assign) and len(node.targets) == 1
                and isinstance(node.targets[0], ast.Name) and node.targets[0].id == RECORD_NAME):
            try:
                return ast.literal_eval(node.value)
            except ValueError:
                return None
    return None


def write_values_in(source: str, values: Mapping[str, Any]) -> str:
    """``source`` with ``params[k]``/``params.get(k...)`` inside ``generate`` replaced by
    ``values[k]``'s literal, other uses of ``params`` there by ``record``, the first line of
    ``generate`` merging ``RECORD`` into the provenance, and ``RECORD`` above ``generate``."""
    tree = ast.parse(source)
    function = next(node for node in tree.body
                    if isinstance(node, ast.FunctionDef) and node.name == "generate")
    edits = [edit for node in function.body for edit in _value_edits(source, node, values)]
    edits.append(_merge_line(source, function))
    edits.append(_record_block(source, function, values))
    return _apply(source, edits)


Edit = tuple[int, int, str]
"""(start offset, end offset, replacement) in the source text."""


def _value_edits(source: str, statement: ast.stmt, values: Mapping[str, Any]) -> list[Edit]:
    edits: list[Edit] = []
    claimed: set[int] = set()
    for node in ast.walk(statement):
        key = _read_key(node)
        if key is not None and key in values:
            edits.append((*_span(source, node), python_literal(values[key])))
            claimed.add(id(node.value if isinstance(node, ast.Subscript)
                           else node.func.value))  # type: ignore[attr-defined]
    for node in ast.walk(statement):
        if (isinstance(node, ast.Name) and node.id == PARAMS_NAME and id(node) not in claimed):
            edits.append((*_span(source, node), LOCAL_NAME))
    return edits


def _read_key(node: ast.AST) -> str | None:
    """``k`` for ``params["k"]`` and ``params.get("k", ...)``; None for anything else."""
    if (isinstance(node, ast.Subscript) and _is_params(node.value)
            and isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str)):
        return node.slice.value
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
            and node.func.attr == "get" and _is_params(node.func.value) and node.args
            and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
        return node.args[0].value
    return None


def _is_params(node: ast.AST) -> bool:
    return isinstance(node, ast.Name) and node.id == PARAMS_NAME


def _merge_line(source: str, function: ast.FunctionDef) -> Edit:
    """Insert ``record = {**params, **RECORD}`` before generate's first statement (after
    its docstring)."""
    body = function.body
    has_doc = isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
    first = body[1] if has_doc and len(body) > 1 else body[0]
    offset = _offset(source, first.lineno, 0)
    indent = " " * first.col_offset
    line = (f"{indent}{LOCAL_NAME} = {{**{PARAMS_NAME}, **{RECORD_NAME}}}"
            f"  # the caller passes only {', '.join(PROVENANCE_KEYS)}\n")
    return offset, offset, line


def _record_block(source: str, function: ast.FunctionDef, values: Mapping[str, Any]) -> Edit:
    lines = "".join(f"    {json.dumps(key)}: {python_literal(value)},\n"
                    for key, value in values.items())
    block = (f"#: this record's values, written in\n{RECORD_NAME} = {{\n{lines}}}\n\n\n")
    start = function.decorator_list[0].lineno if function.decorator_list else function.lineno
    offset = _offset(source, start, 0)
    return offset, offset, block


def python_literal(value: Any) -> str:
    """A Python literal for a JSON value (strings double-quoted like the scripts')."""
    return json.dumps(value) if isinstance(value, str) else repr(value)


def _span(source: str, node: ast.AST) -> tuple[int, int]:
    return (_offset(source, node.lineno, node.col_offset),  # type: ignore[attr-defined]
            _offset(source, node.end_lineno, node.end_col_offset))  # type: ignore[attr-defined]


def _offset(source: str, line: int, column: int) -> int:
    """The character offset of (1-based ``line``, UTF-8 byte ``column``) in ``source``."""
    lines = source.splitlines(keepends=True)
    head = sum(len(text) for text in lines[:line - 1])
    return head + len(lines[line - 1].encode("utf-8")[:column].decode("utf-8"))


def _apply(source: str, edits: list[Edit]) -> str:
    for start, end, text in sorted(edits, key=lambda edit: (edit[0], edit[1]), reverse=True):
        source = source[:start] + text + source[end:]
    return source

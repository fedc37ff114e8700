"""From an LLM's raw reply to a script that may run: extraction, checks, corrections, diffs.

``extract_python_code`` and the deterministic corrections follow thesis §5.3; edit blocks are
how the ``patch`` strategy's replies are applied to the reference script.
"""

from __future__ import annotations

import ast
import difflib
import re
import unicodedata
from dataclasses import dataclass, field

from scenweave.errors import ScenarioError
from scenweave.schemas.scenario_folder import CODE_NAME

SPECIAL_TOKENS = re.compile(
    r"<\|(?:im_start|im_end|endoftext|assistant|user|system|begin_of_text|end_of_text|eot_id)\|>"
    r"|</?s>|<bos>|<eos>")
THINK_BLOCK = re.compile(r"<think>.*?(?:</think>|\Z)", re.S)
FENCE = re.compile(r"```[ \t]*([A-Za-z0-9_+-]*)[^\n]*\n(.*?)(?:```|\Z)", re.S)
CODE_START = re.compile(r"^(?:import |from \S+ import |def |class |@|#!|\"\"\"|''')")
PROSE_LINE = re.compile(r"^[A-Z][A-Za-z']*(?: [A-Za-z',()-]+){3,}[.:!]?$")


@dataclass
class ExtractedCode:
    """The code found in a reply, how it was found, and warnings (e.g. truncation)."""

    code: str
    method: str  # "fenced", "lines" or "none"
    warnings: list[str] = field(default_factory=list)


def extract_python_code(raw: str) -> ExtractedCode:
    """Thesis §5.3: strip special tokens and thinking blocks, take the fenced Python block,
    else scan for the first code-looking line; warn when ``def``s outnumber ``return``s."""
    text = THINK_BLOCK.sub("", SPECIAL_TOKENS.sub("", raw or ""))
    blocks = [body for lang, body in FENCE.findall(text)
              if lang.lower() in ("", "python", "py", "python3")]
    if blocks:
        found = ExtractedCode(_best_block(blocks), "fenced")
    else:
        code = _scan_lines(text)
        found = ExtractedCode(code, "lines" if code else "none")
    found.code = found.code.strip("\n") + "\n" if found.code.strip() else ""
    defs = len(re.findall(r"^\s*def ", found.code, re.M))
    returns = len(re.findall(r"^\s*return\b", found.code, re.M))
    if defs > returns:
        found.warnings.append(f"possibly truncated: {defs} def but {returns} return")
    return found


def _best_block(blocks: list[str]) -> str:
    with_generate = [b for b in blocks if "def generate" in b]
    return max(with_generate or blocks, key=len)


def _scan_lines(text: str) -> str:
    lines = text.splitlines()
    start = next((i for i, line in enumerate(lines) if CODE_START.match(line)), None)
    if start is None:
        return ""
    kept = []
    for line in lines[start:]:
        if PROSE_LINE.match(line) and not line.startswith((" ", "\t")):
            break
        kept.append(line)
    return "\n".join(kept)


# --- deterministic corrections (thesis §5.3) -----------------------------------------------

FAKE_MODULES = ("scenario_builder", "scenariogeneration.core", "scenariogeneration.scenario",
                "carla_scenario", "openscenario")
API_RENAMES = {
    r"\bxosc\.ManeuverGroupSequence\b": "xosc.ManeuverGroup",
    r"\bDynamicsShapes\.Sigmoid\b": "DynamicsShapes.sinusoidal",
    r"\bDynamicsShapes\.Linear\b": "DynamicsShapes.linear",
    r"\bDynamicsShapes\.Step\b": "DynamicsShapes.step",
    r"\bDynamicsShapes\.Cubic\b": "DynamicsShapes.cubic",
    r"\bDynamicsShapes\.Sinusoidal\b": "DynamicsShapes.sinusoidal",
    r"\bDynamicsDimension\.Time\b": "DynamicsDimension.time",
    r"\bDynamicsDimension\.Distance\b": "DynamicsDimension.distance",
    r"\bDynamicsDimension\.Rate\b": "DynamicsDimension.rate",
}
#: enum members written without their enum (``xosc.linear``) -> with it
ENUM_MEMBERS = {"linear": "DynamicsShapes", "sinusoidal": "DynamicsShapes",
                "step": "DynamicsShapes", "cubic": "DynamicsShapes", "time": "DynamicsDimension",
                "distance": "DynamicsDimension", "rate": "DynamicsDimension"}
CHAR_MAP = {"\u2018": "'", "\u2019": "'", "\u201c": '"', "\u201d": '"', "\u2013": "-",
            "\u2014": "-", "\u2212": "-", "\u00a0": " ", "\u2009": " ", "\u202f": " ",
            "\u00d7": "*"}


def _strip_unicode(code: str) -> tuple[str, bool]:
    out = []
    for ch in code:
        ch = CHAR_MAP.get(ch, ch)
        if ord(ch) < 128 or ch.isalnum():
            out.append(ch)
        elif unicodedata.category(ch) in ("Zs",):
            out.append(" ")
        # box drawing, arrows, zero-width and other symbols are dropped
    fixed = "".join(out)
    return fixed, fixed != code


def _comment_fake_imports(code: str) -> tuple[str, bool]:
    names = "|".join(re.escape(m) for m in FAKE_MODULES)
    pattern = re.compile(rf"^(\s*)((?:from\s+(?:{names})\b.*|import\s+(?:{names})\b.*))$", re.M)
    fixed = pattern.sub(r"\1# removed (no such module): \2", code)
    return fixed, fixed != code


def _rename_apis(code: str) -> tuple[str, bool]:
    fixed = code
    for pattern, good in API_RENAMES.items():
        fixed = re.sub(pattern, good, fixed)
    return fixed, fixed != code


def _enum_dot_notation(code: str) -> tuple[str, bool]:
    fixed = re.sub(r"\bxosc\.(" + "|".join(ENUM_MEMBERS) + r")\b(?!\s*\()",
                   lambda m: f"xosc.{ENUM_MEMBERS[m.group(1)]}.{m.group(1)}", code)
    return fixed, fixed != code


def _library_package(code: str) -> tuple[str, bool]:
    """The scenario library imported without its package: ``scenweave.scenario_lib.builder``."""
    fixed = re.sub(r"^(\s*)from\s+(?:scenario_lib\.)?builder\s+import",
                   r"\1from scenweave.scenario_lib.builder import", code, flags=re.M)
    fixed = re.sub(r"^(\s*)import\s+builder\b", r"\1from scenweave.scenario_lib import builder",
                   fixed, flags=re.M)
    return fixed, fixed != code


def _scenario_minor_version(code: str) -> tuple[str, bool]:
    """A direct ``xosc.Scenario(...)`` call must ask for OpenSCENARIO 1.0 (minor version 0)."""
    try:
        tree = ast.parse(code)
    except SyntaxError:
        return code, False
    lines = code.splitlines(keepends=True)
    inserts = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and _dotted(node.func) in ("xosc.Scenario", "Scenario")
                and not any(k.arg == "osc_minor_version" for k in node.keywords)
                and node.end_lineno is not None and node.end_col_offset is not None):
            inserts.append((node.end_lineno - 1, node.end_col_offset - 1))
    for line_no, col in sorted(inserts, reverse=True):
        line = lines[line_no]
        before = line[:col].rstrip()
        sep = "" if before.endswith(("(", ",")) else ", "
        lines[line_no] = line[:col].rstrip() + sep + "osc_minor_version=0" + line[col:]
    return "".join(lines), bool(inserts)


def _dotted(node: ast.AST) -> str:
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    return node.id if isinstance(node, ast.Name) else ""


def _drop_main_block(code: str) -> tuple[str, bool]:
    match = re.search(r"^if\s+__name__\s*==\s*['\"]__main__['\"]\s*:", code, re.M)
    if not match:
        return code, False
    return code[:match.start()].rstrip() + "\n", True


CORRECTIONS = (
    ("unicode", _strip_unicode),
    ("fake_imports", _comment_fake_imports),
    ("api_renames", _rename_apis),
    ("enum_dot_notation", _enum_dot_notation),
    ("library_package", _library_package),
    ("main_block", _drop_main_block),
    ("scenario_minor_version", _scenario_minor_version),
)


def apply_corrections(code: str) -> tuple[str, list[str]]:
    """Apply every deterministic correction; return the code and the names of those applied."""
    applied = []
    for name, correct in CORRECTIONS:
        code, changed = correct(code)
        if changed:
            applied.append(name)
    return code, applied


# --- static checks and diffs ----------------------------------------------------------------

@dataclass
class StaticProblem:
    """Why code cannot run, found without running it."""

    error_type: str
    message: str
    line: int | None = None


def static_check(code: str) -> StaticProblem | None:
    """Compile (never run) the code; it must define ``generate(params, out_path)``."""
    if not code.strip():
        return StaticProblem("EmptyCode", "the reply contained no Python code")
    try:
        tree = ast.parse(code, CODE_NAME)
    except SyntaxError as err:
        kind = type(err).__name__  # SyntaxError, IndentationError, TabError
        return StaticProblem(kind, f"{err.msg} (line {err.lineno})", err.lineno)
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == "generate":
            if len(node.args.args) < 2:
                return StaticProblem("TypeError", "generate() must take (params, out_path)",
                                     node.lineno)
            return None
    return StaticProblem("NameError", "the script defines no function generate(params, out_path)")


def diff_to_reference(reference: str, code: str, reference_name: str = "reference.py",
                      label: str = "attempt") -> str:
    """A unified diff from the reference script to ``code`` ('' when identical)."""
    return "".join(difflib.unified_diff(reference.splitlines(keepends=True),
                                        code.splitlines(keepends=True),
                                        fromfile=reference_name, tofile=label))


# --- edit blocks (the patch strategy) --------------------------------------------------------

EDIT_BLOCK = re.compile(
    r"^<{5,9} ?SEARCH[^\n]*\n(.*?)^={5,9}[^\n]*\n(.*?)^>{5,9} ?REPLACE[^\n]*$", re.S | re.M)
NO_CHANGES = re.compile(r"^\W*NO[ _]CHANGES?\W*$", re.I | re.M)


class PatchError(ScenarioError, ValueError):
    """An edit reply that cannot be applied; the message says which block and why."""


def apply_edit_blocks(reference: str, reply: str) -> tuple[str, int]:
    """Apply the SEARCH/REPLACE blocks of ``reply`` to ``reference``; return code and count."""
    text = THINK_BLOCK.sub("", SPECIAL_TOKENS.sub("", reply or ""))
    blocks = EDIT_BLOCK.findall(text)
    if not blocks:
        if NO_CHANGES.search(text):
            return reference, 0
        raise PatchError("the reply has no SEARCH/REPLACE block and does not say NO CHANGES")
    code = reference
    for number, (search, replace) in enumerate(blocks, start=1):
        code = _replace_once(code, search, replace, number)
    return code, len(blocks)


def _replace_once(code: str, search: str, replace: str, number: int) -> str:
    if not search.strip():
        raise PatchError(f"edit block {number}: the SEARCH part is empty")
    count = code.count(search)
    if count == 1:
        return code.replace(search, replace, 1)
    if count > 1:
        raise PatchError(f"edit block {number}: the SEARCH text occurs {count} times; "
                         "include more lines so it is unique")
    return _replace_by_stripped_lines(code, search, replace, number)


def _replace_by_stripped_lines(code: str, search: str, replace: str, number: int) -> str:
    lines = code.splitlines(keepends=True)
    wanted = [line.strip() for line in search.splitlines() if line.strip()]
    stripped = [line.strip() for line in lines]
    hits = [i for i in range(len(lines) - len(wanted) + 1)
            if stripped[i:i + len(wanted)] == wanted]
    if len(hits) != 1:
        first = wanted[0] if wanted else ""
        raise PatchError(f"edit block {number}: the SEARCH text is not in the reference "
                         f"(first line: {first[:80]!r})")
    start = hits[0]
    return "".join(lines[:start]) + replace + "".join(lines[start + len(wanted):])

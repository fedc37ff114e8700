"""The error taxonomy: one word per failed attempt, the same on the agent and no-LLM paths."""

from __future__ import annotations

import pytest

from scenweave.agent.taxonomy import classify_exception
from scenweave.judge import failure_category


def _finding(code: str, severity: str = "error") -> dict:
    return {"code": code, "severity": severity, "message": "", "line": None}


@pytest.mark.parametrize(("findings", "word"), [
    ([_finding("FIDELITY_SPEED"), _finding("FIDELITY_GAP")], "fidelity"),
    ([_finding("FIDELITY_SPEED"), _finding("XSD_INVALID")], "validation"),
    ([_finding("FIDELITY_SPEED"), _finding("CARLA_BLUEPRINT", "warning")], "fidelity"),
    ([_finding("SEM_NO_BRAKE")], "validation"),
    ([], "validation"),
])
def test_a_failed_validation_is_fidelity_only_when_every_error_is(findings, word):
    assert failure_category(findings) == word


@pytest.mark.parametrize(("error_type", "message", "word"), [
    ("SyntaxError", "", "syntax"),
    ("AttributeError", "module 'x' has no attribute 'y'", "api_hallucination"),
    ("TypeError", "__init__() got an unexpected keyword argument 'speed'", "api_hallucination"),
    ("TypeError", "unsupported operand type(s) for +: 'int' and 'str'", "runtime"),
    ("ModuleNotFoundError", "", "import"),
    ("NameError", "", "name"),
    ("Timeout", "", "timeout"),
    ("ZeroDivisionError", "", "runtime"),
])
def test_a_script_error_gets_its_word(error_type, message, word):
    assert classify_exception(error_type, message) == word

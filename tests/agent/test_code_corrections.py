"""The deterministic fixes of the code-corrections strategy: the closest real attribute of a
module or class, and never a module the error message (text the LLM's code controls) names
outside the allow-list."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from scenweave.agent.repair.code_corrections import allowed_modules, deterministic_fix
from tests.agent.conftest import reference_source

REPO = Path(__file__).resolve().parents[2]
XOSC_SCRIPT = ("from scenariogeneration import xosc\n\n\n"
               "def generate(params, out_path):\n    shape = {}\n")


def fix(code: str, message: str) -> tuple[str, str]:
    return deterministic_fix(code, "AttributeError", message, reference_source("BRAKE"))


def test_the_allow_list_is_the_reference_s_imports_and_scenariogeneration():
    assert set(allowed_modules(reference_source("BRAKE"))) == {
        "scenweave.scenario_lib.builder", "pathlib", "scenariogeneration"}


@pytest.mark.parametrize("code, message, fixed", [
    ("xosc.DynamicsShapes.linar", "type object 'DynamicsShapes' has no attribute 'linar'",
     "xosc.DynamicsShapes.linear"),
    ("xosc.Priority.overwrit", "type object 'Priority' has no attribute 'overwrit'",
     "xosc.Priority.overwrite"),
    ("xosc.DynamicShapes.linear",
     "module 'scenariogeneration.xosc' has no attribute 'DynamicShapes'",
     "xosc.DynamicsShapes.linear"),
    # difflib alone would pick ManeuverGroup; the member read next (overwrite) decides
    ("xosc.ManeuverPriority.overwrite",
     "module 'scenariogeneration.xosc' has no attribute 'ManeuverPriority'",
     "xosc.Priority.overwrite"),
])
def test_the_closest_real_attribute_replaces_the_invented_one(code, message, fixed):
    new, name = fix(XOSC_SCRIPT.format(code), message)
    assert name == "closest_attribute"
    assert new == XOSC_SCRIPT.format(fixed)


def test_a_class_outside_the_allowed_modules_is_left_alone():
    code = XOSC_SCRIPT.format("Fraction.numeratr")
    assert "fractions" not in allowed_modules(reference_source("BRAKE"))
    assert fix(code, "type object 'Fraction' has no attribute 'numeratr'")[0] == code


@pytest.mark.parametrize("module", ["this", "json.tool"])
def test_a_module_named_by_the_error_is_not_imported_unless_allowed(module):
    """In a fresh interpreter, so the check sees exactly what the fix imported."""
    probe = (
        "import sys\n"
        "from agent.repair.code_corrections import deterministic_fix\n"
        "from tests.agent.conftest import reference_source\n"
        f"assert {module!r} not in sys.modules\n"
        f"code = 'import {module}\\nx = {module}.zen\\n'\n"
        f"new, _ = deterministic_fix(code, 'AttributeError', "
        f"\"module '{module}' has no attribute 'zen'\", reference_source('BRAKE'))\n"
        "assert new == code, new\n"
        f"print({module!r} in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "False"

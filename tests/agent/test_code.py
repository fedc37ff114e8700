"""extract_python_code, the deterministic corrections, static checks and edit blocks."""

from __future__ import annotations

import pytest

from scenweave.agent.code import (
    PatchError,
    apply_corrections,
    apply_edit_blocks,
    diff_to_reference,
    extract_python_code,
    static_check,
)

REMOVED = "# removed (no such module): "
SCRIPT = "import math\n\n\ndef generate(params, out_path):\n    return math.pi\n"


def test_fenced_block_is_taken_from_prose():
    found = extract_python_code(f"Sure! Here it is:\n```python\n{SCRIPT}```\nHope it helps.")
    assert found.code == SCRIPT
    assert found.method == "fenced"
    assert found.warnings == []


def test_think_blocks_and_special_tokens_are_stripped():
    raw = ("<|im_start|>assistant\n<think>maybe ```python\nimport os\n```</think>\n"
           f"```python\n{SCRIPT}```<|im_end|>")
    assert extract_python_code(raw).code == SCRIPT


def test_of_several_blocks_the_one_with_generate_wins():
    raw = "```python\nimport os\nprint(os.sep)\nprint(1)\nprint(2)\n```\n" + f"```\n{SCRIPT}```"
    assert extract_python_code(raw).code == SCRIPT


def test_unterminated_fence_keeps_the_truncated_code_and_warns():
    found = extract_python_code("```python\nimport math\n\ndef generate(params, out_path):\n"
                                "    x = 1\n")
    assert found.code.startswith("import math")
    assert "possibly truncated: 1 def but 0 return" in found.warnings


def test_line_scan_without_fences_stops_at_prose():
    raw = f"Here is the script you asked for:\n{SCRIPT}\nThis script builds the scenario for you."
    found = extract_python_code(raw)
    assert found.method == "lines"
    assert found.code == SCRIPT


def test_a_reply_without_code_gives_nothing():
    found = extract_python_code("I cannot help with that request today.")
    assert (found.code, found.method) == ("", "none")


@pytest.mark.parametrize("bad, good, name", [
    ("from scenario_builder import B\n", f"{REMOVED}from scenario_builder import B\n",
     "fake_imports"),
    ("import scenariogeneration.core\n", f"{REMOVED}import scenariogeneration.core\n",
     "fake_imports"),
    ("g = xosc.ManeuverGroupSequence('m')\n", "g = xosc.ManeuverGroup('m')\n", "api_renames"),
    ("s = xosc.DynamicsShapes.Sigmoid\n", "s = xosc.DynamicsShapes.sinusoidal\n", "api_renames"),
    ("s = xosc.linear\n", "s = xosc.DynamicsShapes.linear\n", "enum_dot_notation"),
    ("x = 1 \u2212 2  # \u2500\u2500 box\n", "x = 1 - 2  #  box\n", "unicode"),
    ("s = \u201chero\u201d\n", 's = "hero"\n', "unicode"),
    ("from builder import hero\n", "from scenweave.scenario_lib.builder import hero\n",
     "library_package"),
    ("from scenario_lib.builder import hero\n", "from scenweave.scenario_lib.builder import hero\n",
     "library_package"),
    ("import builder\n", "from scenweave.scenario_lib import builder\n", "library_package"),
    ("x = 1\nif __name__ == '__main__':\n    generate({}, 'a.xosc')\n", "x = 1\n", "main_block"),
])
def test_each_correction(bad, good, name):
    fixed, applied = apply_corrections(bad)
    assert fixed == good
    assert applied == [name]


def test_direct_scenario_constructor_gets_minor_version_zero():
    code = "s = xosc.Scenario('n', 'a', params, entities, sb, road, cat)\n"
    fixed, applied = apply_corrections(code)
    assert fixed == ("s = xosc.Scenario('n', 'a', params, entities, sb, road, cat, "
                     "osc_minor_version=0)\n")
    assert applied == ["scenario_minor_version"]
    again, applied_again = apply_corrections(fixed)
    assert (again, applied_again) == (fixed, [])


def test_correct_code_is_left_alone():
    assert apply_corrections(SCRIPT) == (SCRIPT, [])


@pytest.mark.parametrize("code, error_type", [
    ("", "EmptyCode"),
    ("def generate(params, out_path)\n    return 1\n", "SyntaxError"),
    ("def generate(params, out_path):\nreturn 1\n", "IndentationError"),
    ("def build(params, out_path):\n    return 1\n", "NameError"),
    ("def generate(params):\n    return 1\n", "TypeError"),
])
def test_static_check_finds_what_cannot_run(code, error_type):
    problem = static_check(code)
    assert problem is not None and problem.error_type == error_type


def test_static_check_passes_a_runnable_script():
    assert static_check(SCRIPT) is None


def test_diff_to_reference():
    assert diff_to_reference(SCRIPT, SCRIPT) == ""
    diff = diff_to_reference(SCRIPT, SCRIPT.replace("pi", "e"), "corpus/x.py")
    assert "-    return math.pi" in diff and "+    return math.e" in diff
    assert diff.startswith("--- corpus/x.py")


def test_edit_blocks_apply_in_order():
    reply = ("<<<<<<< SEARCH\n    return math.pi\n=======\n    return math.tau\n>>>>>>> REPLACE\n"
             "<<<<<<< SEARCH\nimport math\n=======\nimport math  # circle\n>>>>>>> REPLACE\n")
    code, edits = apply_edit_blocks(SCRIPT, reply)
    assert edits == 2
    expected = SCRIPT.replace("math.pi", "math.tau").replace("import math\n",
                                                             "import math  # circle\n")
    assert code == expected


def test_edit_block_matches_despite_indentation_drift():
    reply = "<<<<<<< SEARCH\nreturn math.pi\n=======\n    return 3.0\n>>>>>>> REPLACE"
    code, _ = apply_edit_blocks(SCRIPT, reply)
    assert code.endswith("    return 3.0\n")


def test_no_changes_keeps_the_reference():
    assert apply_edit_blocks(SCRIPT, "NO CHANGES") == (SCRIPT, 0)


@pytest.mark.parametrize("reply, message", [
    ("here you go: return 2", "no SEARCH/REPLACE block"),
    ("<<<<<<< SEARCH\nreturn math.e\n=======\nreturn 1\n>>>>>>> REPLACE", "not in the reference"),
    ("<<<<<<< SEARCH\n\n=======\nreturn 1\n>>>>>>> REPLACE", "SEARCH part is empty"),
])
def test_edits_that_do_not_apply_say_why(reply, message):
    with pytest.raises(PatchError, match=message):
        apply_edit_blocks(SCRIPT, reply)


def test_ambiguous_search_is_refused():
    code = "x = 1\nx = 1\n"
    with pytest.raises(PatchError, match="occurs 2 times"):
        apply_edit_blocks(code, "<<<<<<< SEARCH\nx = 1\n=======\nx = 2\n>>>>>>> REPLACE")

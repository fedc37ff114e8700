"""JSON line edits (the ``patch`` strategy and patch-mode variants): applied line by line,
and every way they can fail says which edit and why."""

from __future__ import annotations

import json

import pytest

from scenweave.agent.code import PatchError
from scenweave.agent.edits import apply_edits, edit_grammar, searchable_lines

SCRIPT = 'RECORD = {\n    "speed": 1.0,\n    "lane": -2,\n}\n\n\nx = 1\nx = 1\n'


def reply(*edits: tuple[str, str]) -> str:
    return json.dumps({"edits": [{"search": s, "replace": r} for s, r in edits]})


def test_each_edit_replaces_its_line_keeping_the_indentation():
    code, count = apply_edits(SCRIPT, reply(('    "speed": 1.0,', '"speed": 2.5,'),
                                            ('    "lane": -2,', '    "lane": -1,')))
    assert count == 2 and code == SCRIPT.replace("1.0", "2.5").replace("-2", "-1")


def test_a_replace_of_several_lines_adds_them():
    code, _ = apply_edits(SCRIPT, reply(('    "lane": -2,', '    "lane": -2,\n    "x": 3,')))
    assert '    "lane": -2,\n    "x": 3,\n}' in code


@pytest.mark.parametrize(("edits", "message"), [
    ([("x = 1", "x = 2")], "edit 1: the search line is 2 lines of the script"),
    ([("y = 1", "y = 2")], "edit 1: the search line is not a line of the script"),
])
def test_an_edit_that_cannot_apply_says_which_and_why(edits, message):
    with pytest.raises(PatchError, match=message):
        apply_edits(SCRIPT, reply(*edits))


def test_a_line_edited_twice_takes_the_last_edit():
    code, count = apply_edits(SCRIPT, reply(('    "lane": -2,', '    "lane": -1,'),
                                            ('    "lane": -2,', '    "lane": -3,')))
    assert count == 2 and '"lane": -3,' in code and '"lane": -1,' not in code


def test_a_reply_cut_short_keeps_its_complete_edits():
    cut = reply(('    "speed": 1.0,', '    "speed": 2.5,'), ('    "lane": -2,', '    "la'))[:-8]
    code, count = apply_edits(SCRIPT, cut)
    assert count == 1 and '"speed": 2.5' in code


def test_the_grammar_offers_only_lines_that_occur_once():
    assert searchable_lines(SCRIPT) == ["RECORD = {", '    "speed": 1.0,', '    "lane": -2,',
                                        "}"]
    line_rule = next(r for r in edit_grammar(SCRIPT).splitlines() if r.startswith("line ::="))
    assert line_rule.count(" | ") == 3 and "speed" in line_rule and "x = 1" not in line_rule

"""scripts/doc_tables.py: the docs' counts and per-class rows are made from the class
definitions, and a doc that drifted from them fails here (run the script to rewrite it)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _doc_tables():
    spec = importlib.util.spec_from_file_location("doc_tables", ROOT / "scripts" / "doc_tables.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["doc_tables"] = module  # its dataclass looks its module up there
    spec.loader.exec_module(module)
    return module


doc_tables = _doc_tables()


def test_the_docs_state_what_the_class_definitions_say():
    drifts = [d for _, found in doc_tables.made_docs().values() for d in found]
    assert drifts == [], "run .venv/bin/python scripts/doc_tables.py to rewrite them"


def test_a_wrong_count_is_named_and_made_right():
    text = doc_tables.README.read_text(encoding="utf-8")
    scripts = doc_tables.script_count()
    wrong = text.replace(f"the {scripts} reference scripts", f"the {scripts - 1} reference scripts")
    fixed, drifts = doc_tables.fixed_counts(wrong, doc_tables.README)
    assert drifts == [f"README.md: reference scripts {scripts - 1} -> {scripts}"]
    assert fixed == text


def test_both_numbers_of_a_ratio_are_checked():
    text = doc_tables.README.read_text(encoding="utf-8")
    total = doc_tables.demo_records()
    wrong = text.replace(f"replay: {total}/{total}", f"replay: {total}/{total + 4}")
    fixed, drifts = doc_tables.fixed_counts(wrong, doc_tables.README)
    assert drifts == [f"README.md: demo's replays {total + 4} -> {total}"] and fixed == text


def test_a_row_missing_a_class_or_a_script_is_named_and_made():
    text = doc_tables.CONVENTIONS.read_text(encoding="utf-8")
    assert "| BRAKE, BR_BK (`gen_hw_brake.py`) |" in text
    fixed, drifts = doc_tables.fixed_story_table(
        text.replace("| BRAKE, BR_BK (`gen_hw_brake.py`) |", "| BRAKE (`gen_hw_brake.py`) |"))
    assert drifts == ["scenario-conventions.md: 'BRAKE (`gen_hw_brake.py`)' -> "
                      "'BRAKE, BR_BK (`gen_hw_brake.py`)'"] and fixed == text
    [row] = [line for line in text.split("\n") if line.startswith("| FLF, FLB (")]
    fixed, drifts = doc_tables.fixed_story_table(text.replace(row + "\n", ""))
    assert drifts == ["scenario-conventions.md: no row for gen_hw_flb.py",
                      "scenario-conventions.md: no row for gen_hw_flf.py"]
    assert "| FLB (`gen_hw_flb.py`) | (to be described" in fixed

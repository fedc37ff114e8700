"""``scenweave run --llm replay`` and ``scenweave trace`` from the command line."""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave.cli import cli
from tests.agent.conftest import adapted_source, fenced


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def placed_params(tmp_path, sample_raw, code: str) -> dict:
    """The params (spawn included) a run gives the first ``code`` record: what the LLM's
    script must write in, read from a ``--no-llm`` run of the same record."""
    invoke("run", str(sample_raw), "--out", str(tmp_path / "placed"), "--no-llm", "--no-replay",
           "--classes", code, "--limit", "1", "--run-id", "p")
    found = next((tmp_path / "placed" / "p").glob("*/params.json"))
    return json.loads(found.read_text())


def test_run_with_replay_then_trace(tmp_path, sample_raw):
    reference = adapted_source("BRAKE", placed_params(tmp_path, sample_raw, "BRAKE"))
    replies = tmp_path / "replies.json"
    replies.write_text(json.dumps(["no code here", fenced(reference)]))
    runs = tmp_path / "runs"
    result = invoke("run", str(sample_raw), "--out", str(runs), "--llm", "replay",
                    "--replay-file", str(replies), "--classes", "BRAKE", "--limit", "1",
                    "--sandbox", "bwrap", "--run-id", "r1")
    assert result.exit_code == 0, result.output
    assert "1 repaired" in result.output and "report.html" in result.output
    summary = json.loads((runs / "r1" / "summary.json").read_text())
    scenario = summary["scenarios"][0]
    assert (scenario["status"], scenario["attempts"], scenario["error_taxonomy"]) == (
        "repaired", 2, ["syntax"])
    assert scenario["llm"] == {"backend": "replay", "model": "replay"}
    assert summary["error_taxonomy"] == {"syntax": 1}
    assert (summary["attempts"], summary["first_attempt_success"], summary["fallbacks"]) == (
        2, 0, 0)
    assert summary["node_latency_s"]["execute"]["scenarios"] == 1
    assert summary["node_latency_s"]["execute"]["total"] == scenario["node_latency_s"]["execute"]
    assert set(scenario["node_latency_s"]) == {"retrieve", "generate", "execute", "repair",
                                               "validate"}
    run_json = json.loads((runs / "r1" / "run.json").read_text())
    assert run_json["mode"] == "agent" and run_json["agent"]["llm"] == "replay"

    shown = invoke("trace", scenario["scenario_id"], "--runs", str(runs))
    assert shown.exit_code == 0
    order = [line.split("]")[1].split()[0] for line in shown.output.splitlines()
             if line.startswith("[")]
    assert order == ["spawn", "retrieve", "generate", "execute", "repair", "execute", "validate"]
    assert "raw reply:" in shown.output and "no code here" in shown.output
    assert "diff to the reference:" in shown.output
    assert "error EmptyCode" in shown.output and "taxonomy: syntax" in shown.output
    assert "checkpoints:" in shown.output

    logged = json.loads(invoke("logs", "--json", "--scenario", scenario["scenario_id"]).output)
    assert [c["purpose"] for c in logged] == ["repair", "generate"]  # newest first
    assert {c["backend"] for c in logged} == {"replay"} and logged[1]["reply"] == "no code here"
    assert "replay/replay" in invoke("logs", "-n", "1").output

    as_json = json.loads(invoke("trace", scenario["scenario_id"], "--runs", str(runs),
                                "--json").output)
    assert [e["node"] for e in as_json][:3] == ["spawn", "retrieve", "generate"]
    times = [e["t_s"] for e in as_json]
    assert times == sorted(times)


def test_trace_of_an_unknown_scenario_is_one_clear_line(tmp_path):
    result = CliRunner().invoke(cli, ["trace", "NOPE_1", "--runs", str(tmp_path)])
    assert result.exit_code == 1
    assert "no trace of scenario 'NOPE_1'" in result.output and "--runs" in result.output


def test_replay_without_a_file_is_a_usage_error(tmp_path, sample_raw):
    result = CliRunner().invoke(cli, ["run", str(sample_raw), "--out", str(tmp_path),
                                      "--llm", "replay"])
    assert result.exit_code == 2
    assert "--replay-file" in result.output


def test_unknown_repair_strategy_names_the_choices(tmp_path, sample_raw):
    result = CliRunner().invoke(cli, ["run", str(sample_raw), "--out", str(tmp_path),
                                      "--repair", "prayer"])
    assert result.exit_code == 2
    assert "code-corrections" in result.output and "error-feedback" in result.output

"""The benchmark's aggregation on synthetic agent-like outcomes and on a real run, and the
benchmark end to end with the ``reference`` model (no LLM)."""

from __future__ import annotations

import base64
import json
import random

import lxml.html
import numpy as np
import pytest
from click.testing import CliRunner
from lxml import etree

from scenweave.bench import BenchError, BenchSettings, agent_settings_for, aggregate, run_bench
from scenweave.cli import cli
from scenweave.presentation.metrics import percentile, projected_curve

SVG = "{http://www.w3.org/2000/svg}"


def outcome(cls: str, status: str, latency: float, attempts: int = 1, first: bool = False,
            errors: tuple[str, ...] = (), tokens: tuple[int, int] = (0, 0)) -> dict:
    """An outcome shaped like the agent's (pipeline keys, agent fields)."""
    return {"scenario_id": f"{cls}_{status}_{latency}", "maneuver_class": cls,
            "domain": "highway", "status": status, "attempts": attempts,
            "first_attempt_success": first, "fallback": status == "fallback",
            "timings_s": {"total": latency}, "tokens_in": tokens[0], "tokens_out": tokens[1],
            "error_taxonomy": list(errors)}


@pytest.fixture
def two_models() -> dict[str, list[dict]]:
    shaky = [outcome("LCB", "ok", 10, first=True, tokens=(1000, 400)),
             outcome("LCB", "ok", 20, first=True, tokens=(1000, 500)),
             outcome("LCB", "repaired", 30, attempts=2, errors=("syntax",), tokens=(2100, 900)),
             outcome("LCB", "fallback", 40, attempts=3,
                     errors=("syntax", "api_hallucination", "api_hallucination")),
             outcome("COUTF", "failed", 50, attempts=3, errors=("name",))]
    steady = [outcome(c, "ok", 25, first=True, tokens=(900, 300)) for c in ("LCB", "COUTF")]
    return {"dscoder": shaky, "qwen": steady}


def test_rates_latency_tokens_and_errors_per_model(two_models):
    summary = aggregate(two_models)
    shaky = summary["models"]["dscoder"]["overall"]
    assert shaky["n"] == 5
    assert shaky["success_rate"] == 0.6  # ok, ok, repaired; the fallback is the LLM failing
    assert shaky["delivered_rate"] == 0.8
    assert shaky["first_attempt_rate"] == 0.4
    assert shaky["fallbacks"] == 1
    assert shaky["latency_s"]["mean"] == 30 and shaky["latency_s"]["p50"] == 30
    assert shaky["latency_s"]["p95"] == pytest.approx(48)
    assert shaky["tokens_in"] == 4100 and shaky["tokens_out"] == 1800
    assert shaky["error_taxonomy"] == {"api_hallucination": 2, "name": 1, "syntax": 2}
    assert summary["models"]["qwen"]["overall"]["success_rate"] == 1.0


def test_the_thesis_tables_are_by_class_and_model(two_models):
    summary = aggregate(two_models)
    assert summary["latency_table"] == {"COUTF": {"dscoder": 50, "qwen": 25},
                                        "LCB": {"dscoder": 25, "qwen": 25}}
    assert summary["error_table"]["syntax"] == {"dscoder": 2, "qwen": 0}
    lcb = summary["models"]["dscoder"]["by_class"]["LCB"]
    assert (lcb["n"], lcb["success_rate"], lcb["first_attempt_rate"]) == (4, 0.75, 0.5)
    assert summary["models"]["dscoder"]["by_class"]["COUTF"]["success_rate"] == 0.0


def test_percentiles_agree_with_numpy():
    rng = random.Random(3)
    for _ in range(50):
        values = [rng.uniform(0, 100) for _ in range(rng.randint(1, 40))]
        for q in (50, 95):
            assert percentile(values, q) == pytest.approx(np.percentile(values, q))


def test_projection_counts_scenarios_in_an_hour():
    assert projected_curve([10.0])[-1] == (3600.0, 360)
    thinned = projected_curve([1.0, 2.0], max_points=50)
    assert len(thinned) <= 51 and thinned[-1][1] == 2400


def test_reference_benchmark_aggregates_real_outcomes(tmp_path):
    settings = BenchSettings(models=("reference",), classes=("BRAKE", "U4_1"), per_class=2)
    result = run_bench(settings, tmp_path, bench_id="b")
    written = json.loads((tmp_path / "b" / "bench.json").read_text())
    run_summary = json.loads((result.run_dirs["reference"] / "summary.json").read_text())
    overall = written["models"]["reference"]["overall"]
    assert overall["n"] == run_summary["total"] == 4
    assert set(written["models"]["reference"]["by_class"]) == {"BRAKE", "U4_1"}
    latencies = [o["timings_s"]["total"] for o in run_summary["scenarios"]]
    assert overall["latency_s"]["mean"] == pytest.approx(np.mean(latencies), abs=1e-4)
    assert overall["counts"]["failed"] == run_summary["counts"]["failed"]
    for name in written["figures"].values():
        assert etree.fromstring((tmp_path / "b" / name).read_bytes()).tag == f"{SVG}svg"
    assert "Table 6.2" in (tmp_path / "b" / "bench.html").read_text()
    assert_boxplots(tmp_path / "b", written, ["reference"])


def test_cli_prints_one_line_per_benchmark(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--models", "reference", "--classes", "LCF",
                                      "--per-class", "1", "--out", str(tmp_path),
                                      "--bench-id", "cli"])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("bench cli: reference: SR ")


def test_an_unknown_backend_is_refused_by_name():
    assert agent_settings_for("gpt")("reference").no_llm  # the reference needs no LLM
    with pytest.raises(BenchError, match="--llm 'gpt'"):
        agent_settings_for("gpt")("qwen2.5-coder:7b")


def replayed_bench(tmp_path, models: str, repair: str, classes: str, out, bench_id: str):
    """``scenweave bench`` with every model answering "NO CHANGES" to the patch prompt: the
    worked example's values kept, so every scenario ends in the fallback."""
    replies = tmp_path / "replies.json"
    replies.write_text(json.dumps({"*": ["NO CHANGES"] * 3}))
    result = CliRunner().invoke(cli, ["bench", "--models", models, "--llm", "replay",
                                      "--replay-file", str(replies), "--repair", repair,
                                      "--classes", classes, "--per-class", "1",
                                      "--out", str(out), "--bench-id", bench_id])
    return result, replies


def test_agent_benchmark_with_replayed_models(tmp_path):
    result, replies = replayed_bench(tmp_path, "model-a,model-b", "patch", "BRAKE,LCF",
                                     tmp_path, "replay")
    assert result.exit_code == 0, result.output
    assert "model-a: SR 0%, 1st 0%" in result.output  # a fallback is no LLM success
    assert "model-b: SR 0%, 1st 0%" in result.output
    aggregate = json.loads((tmp_path / "replay" / "bench.json").read_text())
    outcomes = json.loads((tmp_path / "replay" / "runs" / "model-a" / "summary.json")
                          .read_text())["scenarios"]
    assert {o["llm"]["model"] for o in outcomes} == {"model-a"}
    assert {o["repair"] for o in outcomes} == {"patch"}
    assert set(aggregate["models"]) == {"model-a", "model-b"}
    assert aggregate["settings"]["repair"] == "patch"
    assert aggregate["settings"]["replay_file"] == str(replies)
    assert_boxplots(tmp_path / "replay", aggregate, ["model-a", "model-b"])


def assert_boxplots(root, aggregate: dict, models: list[str]) -> None:
    """Fig. 6.3 per model: listed in bench.json, an SVG with a box per class of the model's
    outcomes, drawn inline in bench.html."""
    html = lxml.html.fromstring((root / "bench.html").read_bytes())
    shown = {img.get("alt"): img.get("src") for img in html.xpath("//figure/img")}
    for model in models:
        name = aggregate["figures"][f"latency_boxplot/{model}"]
        assert name.startswith("fig6_3_") and name.endswith(".svg") and model in name
        root_element = etree.parse(str(root / name)).getroot()  # raises unless well-formed
        assert int(root_element.get("width")) > 100 and int(root_element.get("height")) > 100
        boxes = {g.get("data-box") for g in root_element.iter(f"{SVG}g")
                 if g.get("class") == "box"}
        assert boxes == set(aggregate["models"][model]["by_class"])  # something is drawn
        src = shown[f"latency boxplot {model}"]
        assert src.startswith("data:image/svg+xml;base64,")
        assert base64.b64decode(src.split(",", 1)[1]) == (root / name).read_bytes()


def test_an_unknown_repair_strategy_stops_the_benchmark_before_it_runs(tmp_path):
    result, _ = replayed_bench(tmp_path, "model-a", "typo", "BRAKE", tmp_path / "bench", "b")
    assert result.exit_code == 1
    [line] = result.output.splitlines()
    assert "--repair 'typo'" in line
    assert "code-corrections, error-feedback, patch" in line
    assert not (tmp_path / "bench" / "b").exists()  # no records made, no run started

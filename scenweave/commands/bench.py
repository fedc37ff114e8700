"""``scenweave bench --models A,B``: the agent over the same sample records per model."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from scenweave import exit_codes
from scenweave.bench import REFERENCE, THESIS_CLASSES, BenchError, BenchSettings, run_bench
from scenweave.commands.agent_options import (
    LlmChoice,
    auto_llm,
    json_option,
    map_option,
    replay_settings_for,
)


def _names(text: str) -> tuple[str, ...]:
    return tuple(part.strip() for part in text.split(",") if part.strip())


@click.command("bench")
@click.option("--models", required=True,
              help="Comma-separated model names, e.g. qwen2.5-coder:7b,codellama:7b; "
                   "'reference' = the reference scripts without an LLM.")
@click.option("--classes", default=",".join(THESIS_CLASSES), show_default=True,
              help="Comma-separated class codes.")
@click.option("--per-class", default=5, show_default=True, type=click.IntRange(1),
              help="Records per class (the thesis used 5).")
@click.option("--llm", type=LlmChoice(), default="ollama", show_default=True,
              help="LLM backend the agent uses (auto: Ollama when it answers; none: only "
                   "--models reference makes sense).")
@click.option("--repair", default="error-feedback", show_default=True,
              help="Repair strategy of the agent.")
@click.option("--replay-file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="For --llm replay: recorded replies.")
@click.option("--data", type=click.Path(exists=True, path_type=Path),
              help="Records to use instead of seeded sample data.")
@click.option("--seed", default=7, show_default=True, help="Seed of the sample data.")
@click.option("--out", "out_root", default="bench", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Folder for benchmarks.")
@click.option("--bench-id", help="Name of the benchmark folder; an existing one is resumed.")
@click.option("--replay/--no-replay", default=None,
              help="Play every scenario in esmini and judge it [default: on when found].")
@json_option("bench.json's aggregate")
@map_option()
def bench(models: str, classes: str, per_class: int, llm: str, repair: str,
          replay_file: Path | None, data: Path | None, seed: int, out_root: Path,
          bench_id: str | None, replay: bool | None, as_json: bool, map_ref: Any) -> None:
    """Benchmark models on the same records: SR, first-attempt rate, latency, tokens, errors."""
    if not _names(models):
        raise click.BadParameter("give at least one model", param_hint="--models")
    if llm == "auto":
        llm = auto_llm(None)
    if llm == "none" and set(_names(models)) != {REFERENCE}:
        raise click.BadParameter("without an LLM only --models reference can run",
                                 param_hint="--llm")
    settings = BenchSettings(models=_names(models), classes=_names(classes),
                             per_class=per_class, llm=llm, seed=seed,
                             repair=repair.replace("-", "_"), replay_file=replay_file,
                             replay=replay_settings_for(replay), map=map_ref.logic_file)
    try:
        result = run_bench(settings, out_root, bench_id=bench_id, data=data)
    except BenchError as err:
        raise click.ClickException(str(err)) from err
    click.echo(json.dumps(result.aggregate, indent=1) if as_json else result.line())
    exit_codes.finish(result.problems)

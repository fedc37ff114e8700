"""The multi-model benchmark (thesis §6.1–6.2): the same records through the agent per model.

Each model gets its own run folder (``<bench>/runs/<model>/``, made by ``run_batch``, so an
interrupted benchmark resumes), and the outcomes of all models are aggregated into
``bench.json``: per model and per class the success rate, first-attempt rate, latency
(mean/std/p50/p95), tokens and the error taxonomy (Tables 6.2, 6.3), plus the figures of
Figs. 6.1, 6.2, 6.3 (per model) and 6.4 as SVG files and a self-contained ``bench.html``.

The model name ``reference`` stands for no LLM at all (the deterministic reference scripts):
a baseline for latency and a way to run the whole benchmark machinery without a model.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from scenweave.errors import InputError
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.presentation.bench_report import BENCH_FILE, model_dir_name, write_bench
from scenweave.presentation.metrics import by_class, metrics
from scenweave.presentation.report import pct
from scenweave.progress import progress
from scenweave.runner import run_batch
from scenweave.schemas.scenario_folder import SUMMARY_FILE

#: the 11 highway classes of the thesis benchmark (BR_BK shares BRAKE's script)
THESIS_CLASSES = ("BRAKE", "CINF", "CINB", "COUTF", "COUTB", "LCF", "LCB", "FLF", "FLB", "FRF",
                  "FRB")
REFERENCE = "reference"


class BenchError(InputError):
    """The benchmark cannot run as configured; the message names the option to change."""


@dataclass
class BenchSettings:
    """What to benchmark: which models, on which records, with which LLM backend."""

    models: tuple[str, ...]
    classes: tuple[str, ...] = THESIS_CLASSES
    per_class: int = 5
    llm: str = "ollama"
    repair: str = "error_feedback"
    replay_file: Path | None = None
    seed: int = 7
    top_n: int = 5
    #: player.ReplaySettings: every scenario is played in esmini and judged (None: no replay)
    replay: Any = None
    #: the map scenarios are made for: a bundled town's name or an .xodr path (None: Town04)
    map: str | None = None


@dataclass
class BenchResult:
    """Where the benchmark wrote, and its aggregate."""

    root: Path
    aggregate: dict
    run_dirs: dict[str, Path] = field(default_factory=dict)

    @property
    def problems(self) -> bool:
        """A record was refused or a scenario failed in some model's run (exit code 1)."""
        for run_dir in self.run_dirs.values():
            summary = json.loads((Path(run_dir) / SUMMARY_FILE).read_text(encoding="utf-8"))
            refused = any(i.get("severity", "error") == "error"
                          for i in summary.get("input_issues", []))
            if refused or summary["counts"].get("failed") or not summary["total"]:
                return True
        return False

    def line(self) -> str:
        """The one-line summary printed at the end of ``scenweave bench``."""
        parts = []
        for model, entry in self.aggregate["models"].items():
            m = entry["overall"]
            mean = m["latency_s"]["mean"]
            latency = "–" if mean is None else f"{mean:.2f}"
            parts.append(f"{model}: SR {pct(m['success_rate'])}, "
                         f"1st {pct(m['first_attempt_rate'])}, {latency} s")
        return f"bench {self.root.name}: " + "; ".join(parts) + f" -> {self.root / BENCH_FILE}"


def agent_settings_for(llm: str, replay: Any = None,
                       **agent: Any) -> Callable[[str], PipelineSettings]:
    """Pipeline settings per model name: the agent with that model on backend ``llm``;
    ``agent`` holds further AgentSettings fields (repair, replay_file, ...); ``replay`` plays
    every scenario (the reference's too) in esmini."""
    def settings(model: str) -> PipelineSettings:
        if model == REFERENCE:
            return PipelineSettings(no_llm=True, replay=replay)
        try:
            from scenweave.agent import AgentSettings
            from scenweave.agent.llm.backends import backend_names
        except ImportError as err:
            raise BenchError(f"model {model!r} needs the agent, which cannot be imported here "
                             f"({err}); benchmark --models {REFERENCE} only") from err
        if llm not in backend_names():
            raise BenchError(f"--llm {llm!r}: model {model!r} needs one of "
                             f"{', '.join(backend_names())}")
        try:
            agent_settings = AgentSettings(model=model, llm=llm, replay=replay, **agent)
        except ValueError as err:  # e.g. an unknown --repair: the message names the option
            raise BenchError(str(err)) from err
        return PipelineSettings(no_llm=False, agent=agent_settings, replay=replay)

    return settings


def sample_records(root: Path, settings: BenchSettings) -> Path:
    """Seeded MOOVE-format sample data for the benchmark (made once, reused on resume)."""
    from scenweave.ingest.samples import write_highway_samples, write_urban_samples

    data = root / "data"
    if not data.exists():
        staging = Path(tempfile.mkdtemp(dir=root, prefix=".data."))
        write_highway_samples(staging / "highway", seed=settings.seed, per_class=settings.per_class)
        write_urban_samples(staging / "urban", seed=settings.seed, per_class=settings.per_class)
        staging.rename(data)
    return data


def run_bench(settings: BenchSettings, out_root: Path, bench_id: str | None = None,
              data: Path | None = None,
              settings_for: Callable[[str], PipelineSettings] | None = None) -> BenchResult:
    """Run every model over the selected records, aggregate, write json, figures and html."""
    settings_for = settings_for or agent_settings_for(
        settings.llm, replay=settings.replay, repair=settings.repair,
        replay_file=settings.replay_file)
    pipelines = {model: settings_for(model) for model in settings.models}  # fail before running
    root = Path(out_root) / (bench_id or datetime.now(UTC).strftime("bench-%Y%m%d-%H%M%S"))
    root.mkdir(parents=True, exist_ok=True)
    data = Path(data) if data else sample_records(root, settings)
    selection = InputSelection(classes=settings.classes, per_class=settings.per_class)
    outcomes, run_dirs = {}, {}
    for model in progress(settings.models, desc="models", total=len(settings.models)):
        pipelines[model].top_n = settings.top_n
        pipelines[model].map = settings.map
        result = run_batch(data, root / "runs", selection, pipelines[model],
                           run_id=model_dir_name(model))
        outcomes[model] = result.summary["scenarios"]
        run_dirs[model] = result.folder.root
    summary = aggregate(outcomes)
    replay = settings.replay_file
    summary["settings"] = {**asdict(settings), "data": str(data),
                           "replay_file": str(replay) if replay else None}
    summary["runs"] = {model: str(path) for model, path in run_dirs.items()}
    write_bench(root, summary, outcomes)
    return BenchResult(root, summary, run_dirs)


def aggregate(outcomes_by_model: dict[str, list[dict]]) -> dict:
    """``bench.json``: metrics per model and per model and class, and the thesis tables."""
    models = {model: {"overall": metrics(outcomes),
                      "by_class": {code: metrics(group)
                                   for code, group in by_class(outcomes).items()}}
              for model, outcomes in outcomes_by_model.items()}
    classes = sorted({code for entry in models.values() for code in entry["by_class"]})
    errors = sorted({e for entry in models.values() for e in entry["overall"]["error_taxonomy"]})
    return {
        "written_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "models": models,
        # thesis Table 6.2: mean latency (s/scenario) by class and model
        "latency_table": {code: {model: entry["by_class"].get(code, {}).get("latency_s", {})
                                 .get("mean") for model, entry in models.items()}
                          for code in classes},
        # thesis Table 6.3: errors by category and model, over all attempts
        "error_table": {error: {model: entry["overall"]["error_taxonomy"].get(error, 0)
                                for model, entry in models.items()} for error in errors},
    }

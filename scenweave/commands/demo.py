"""``scenweave demo``: the main job end to end on built-in sample data."""

from __future__ import annotations

from pathlib import Path

import click

from ingest import ingest_directory
from ingest.samples import write_highway_samples, write_urban_samples
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.runner import run_batch


@click.command("demo")
@click.option("--out", "out_dir", default="runs/demo", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Where the demo writes.")
@click.option("--seed", default=7, show_default=True, help="Seed of the sample data.")
@click.option("--per-class", default=3, show_default=True, type=click.IntRange(1),
              help="Sample records per class.")
def demo(out_dir: Path, seed: int, per_class: int) -> None:
    """Make sample data, ingest it, and turn every record into a validated scenario."""
    raw = out_dir / "sample_data"
    write_highway_samples(raw / "highway", seed, per_class)
    write_urban_samples(raw / "urban", seed, per_class)
    report = ingest_directory(raw, out_dir / "records")
    click.echo(f"demo: sample data in {raw}; {report.records_written} canonical records in "
               f"{out_dir / 'records'} ({len(report.errors)} input errors)")
    result = run_batch(out_dir / "records", out_dir / "runs", InputSelection(),
                       PipelineSettings(no_llm=True), run_id="no-llm")
    click.echo(result.line())

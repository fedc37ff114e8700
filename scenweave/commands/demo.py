"""``scenweave demo``: the main job end to end on built-in sample data."""

from __future__ import annotations

from pathlib import Path

import click

from ingest import ingest_directory
from ingest.samples import write_highway_samples, write_urban_samples


@click.command("demo")
@click.option("--out", "out_dir", default="runs/demo", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Where the demo writes.")
@click.option("--seed", default=7, show_default=True)
@click.option("--per-class", default=5, show_default=True, type=click.IntRange(1))
def demo(out_dir: Path, seed: int, per_class: int) -> None:
    """Make sample data, ingest it, and run the pipeline on it."""
    raw = out_dir / "sample_data"
    write_highway_samples(raw / "highway", seed, per_class)
    write_urban_samples(raw / "urban", seed, per_class)
    report = ingest_directory(raw, out_dir / "records")
    click.echo(f"demo: {report.records_written} canonical records, {len(report.errors)} errors "
               f"-> {out_dir}")

"""``scenweave sample-data DIR``: seeded sample data in the MOOVE formats."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave.commands.agent_options import json_option
from scenweave.ingest.layouts import load_layouts
from scenweave.ingest.samples import write_highway_samples, write_urban_samples


@click.command("sample-data")
@click.argument("out_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--seed", default=7, show_default=True, help="Random seed (same seed, same files).")
@click.option("--per-class", default=20, show_default=True, type=click.IntRange(1),
              help="Rows per highway class and files per urban class.")
@click.option("--layout", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Highway column-layout JSON (default: schemas/highway_layouts.json).")
@click.option("--phased", default=0, show_default=True, type=click.IntRange(0),
              help="More rows per car-following class that need a speed profile of two or "
                   "more phases (after the --per-class rows, which stay the same).")
@json_option("the files written")
def sample_data(out_dir: Path, seed: int, per_class: int, layout: Path | None, phased: int,
                as_json: bool) -> None:
    """Write realistic sample data: 12 highway .npy files and 5 urban ADScene folders."""
    highway = write_highway_samples(out_dir / "highway", seed, per_class, load_layouts(layout),
                                    phased=phased)
    urban = write_urban_samples(out_dir / "urban", seed, per_class)
    if as_json:
        click.echo(json.dumps({"highway": [str(p) for p in highway],
                               "urban": [str(p) for p in urban]}, indent=1))
        return
    click.echo(f"sample data: {len(highway)} highway files ({per_class} rows each), "
               f"{len(urban)} urban files -> {out_dir}")

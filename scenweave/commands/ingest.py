"""``scenweave ingest RAW_DIR --out DIR``: raw MOOVE data -> canonical records + report."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave.ingest import ingest_directory
from scenweave.ingest.batch import REPORT_NAME
from scenweave.ingest.highway import DEFAULT_BINNING

SHOWN_ISSUES = 20


@click.command("ingest")
@click.argument("raw_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for highway/<CLASS>.json, urban/<CODE>.json and the report.")
@click.option("--layout", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Highway column-layout JSON (default: schemas/highway_layouts.json).")
@click.option("--binning", default=DEFAULT_BINNING, show_default=True,
              help="Binning version written into highway scenario ids.")
@click.option("--strict", is_flag=True, help="Exit with status 1 if any input had an error.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def ingest(raw_dir: Path, out_dir: Path, layout: Path | None, binning: str, strict: bool,
           as_json: bool) -> None:
    """Canonicalise highway .npy and urban ADScene files; bad rows are reported, not fatal."""
    report = ingest_directory(raw_dir, out_dir, layout, binning)
    if as_json:
        click.echo(json.dumps(report.to_dict(), indent=1))
    else:
        for issue in report.issues[:SHOWN_ISSUES]:
            click.echo(f"{issue.severity}: {issue.line()}", err=True)
        if len(report.issues) > SHOWN_ISSUES:
            click.echo(f"... {len(report.issues) - SHOWN_ISSUES} more in {REPORT_NAME}", err=True)
        click.echo(f"ingest: {report.records_written} records from {report.files_read} files, "
                   f"{len(report.errors)} errors -> {out_dir} (report: {out_dir / REPORT_NAME})")
    if strict and report.errors:
        raise SystemExit(1)

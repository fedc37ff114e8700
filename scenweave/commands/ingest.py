"""``scenweave ingest RAW_DIR --out DIR``: raw MOOVE data -> canonical records + report."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import json_option
from scenweave.console import problem_lines
from scenweave.ingest import ingest_directory
from scenweave.ingest.highway import DEFAULT_BINNING
from scenweave.schemas.scenario_folder import INGEST_REPORT_NAME


@click.command("ingest")
@click.argument("raw_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for highway/<CLASS>.json, urban/<CODE>.json and the report.")
@click.option("--layout", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Highway column-layout JSON (default: schemas/highway_layouts.json).")
@click.option("--binning", default=DEFAULT_BINNING, show_default=True,
              help="Binning version written into highway scenario ids.")
@click.option("--strict", is_flag=True, hidden=True,
              help="Kept for old scripts: exit status 1 on input errors is the default now.")
@json_option("the ingest report")
def ingest(raw_dir: Path, out_dir: Path, layout: Path | None, binning: str, strict: bool,
           as_json: bool) -> None:
    """Canonicalise highway .npy and urban ADScene files into OUT (its old records are
    replaced); bad rows are reported, not fatal. Exit status 1 when a record was refused or
    none was written."""
    report = ingest_directory(raw_dir, out_dir, layout, binning)
    if as_json:
        click.echo(json.dumps(report.to_dict(), indent=1))
    else:
        click.echo(f"ingest: {report.records_written} records from {report.files_read} files, "
                   f"{len(report.errors)} refused -> {out_dir} "
                   f"(report: {out_dir / INGEST_REPORT_NAME})")
        issues = [issue.to_dict() for issue in report.issues]
        for line in problem_lines(issues, where=str(out_dir / INGEST_REPORT_NAME)):
            click.echo(line, err=True)
    exit_codes.finish(bool(report.errors) or report.records_written == 0)

"""``scenweave mine DATA --out DIR``: every manoeuvre in public trajectory data, as records."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import class_codes, json_option
from scenweave.console import counted_lines
from scenweave.progress import progress


@click.command("mine")
@click.argument("data", type=click.Path(exists=True, path_type=Path))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for highway/<CLASS>.json, mining_report.json and .html.")
@click.option("--thresholds", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Detection thresholds JSON (default: mining/thresholds.json).")
@click.option("--classes", callback=class_codes, help="Only these classes, e.g. BRAKE,CINF.")
@json_option("the mining report")
def mine(data: Path, out_dir: Path, thresholds: Path | None, classes: tuple[str, ...],
         as_json: bool) -> None:
    """Read CommonRoad XML, NGSIM CSV or highD files (a file or a folder), find the
    manoeuvres of the MOOVE classes in them and write each as a canonical record. Exit status
    1 when an event found was refused or no record was written."""
    from scenweave.mining.mine import REPORT_NAME, mine_recordings
    from scenweave.mining.readers import read_recordings
    from scenweave.mining.thresholds import ThresholdsError, load_thresholds
    from scenweave.presentation.mining_report import write_mining_report

    warnings: list[str] = []
    try:
        limits = load_thresholds(thresholds, warnings)
    except ThresholdsError as err:
        raise click.BadParameter(str(err), param_hint="--thresholds") from err
    report = mine_recordings(progress(read_recordings(data), desc="mining"), out_dir, limits,
                             classes)
    report.warnings[:0] = warnings
    html = write_mining_report(out_dir / REPORT_NAME)
    if as_json:
        click.echo(json.dumps(report.to_dict(), indent=1))
    else:
        _tell(report, out_dir, html)
    # an event found but refused counts as a problem, as does an input nothing was read from
    exit_codes.finish(not sum(report.written.values()) or bool(report.skipped))


def _tell(report: Any, out_dir: Path, html: Path) -> None:
    """The summary line, then what was refused and the warnings, a few of each."""
    from scenweave.mining.mine import REPORT_NAME

    by_class = ", ".join(f"{c} {n}" for c, n in sorted(report.written.items())) or "none"
    rate = report.vehicle_hours / report.seconds if report.seconds else 0.0
    click.echo(f"mine: {sum(report.written.values())} records ({by_class}) from "
               f"{len(report.files)} files, {report.vehicle_hours:.2f} vehicle-hours in "
               f"{report.seconds:.1f} s ({rate:.2f} vehicle-hours/s), "
               f"{len(report.skipped)} refused -> {out_dir} (open {html})")
    where = str(out_dir / REPORT_NAME)
    lines = []
    if report.skipped:
        lines += counted_lines(
            f"refused: {len(report.skipped)} events no scenario can play back",
            [f"{skip['file']}: {skip['scenario_id']}"
             + (f", field '{skip['field']}'" if skip.get("field") else "")
             + f": {skip['reason']}" for skip in report.skipped], where)
    if report.warnings:
        lines += counted_lines(f"warnings: {len(report.warnings)}", report.warnings, where)
    for line in lines:
        click.echo(line, err=True)

"""``scenweave mine DATA --out DIR``: every manoeuvre in public trajectory data, as records."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave.progress import progress

SHOWN_SKIPS = 10


@click.command("mine")
@click.argument("data", type=click.Path(exists=True, path_type=Path))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for highway/<CLASS>.json, mining_report.json and .html.")
@click.option("--thresholds", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Detection thresholds JSON (default: mining/thresholds.json).")
@click.option("--classes", default="", help="Only these classes, e.g. BRAKE,CINF.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def mine(data: Path, out_dir: Path, thresholds: Path | None, classes: str,
         as_json: bool) -> None:
    """Read CommonRoad XML, NGSIM CSV or highD files (a file or a folder), find the
    manoeuvres of the MOOVE classes in them and write each as a canonical record."""
    from scenweave.mining.mine import REPORT_NAME, mine_recordings
    from scenweave.mining.readers import read_recordings
    from scenweave.mining.thresholds import ThresholdsError, load_thresholds
    from scenweave.mining_report import write_mining_report

    warnings: list[str] = []
    try:
        limits = load_thresholds(thresholds, warnings)
    except ThresholdsError as err:
        raise click.BadParameter(str(err), param_hint="--thresholds") from err
    wanted = tuple(c.strip().upper() for c in classes.split(",") if c.strip())
    report = mine_recordings(progress(read_recordings(data), desc="mining"), out_dir, limits,
                             wanted)
    report.warnings[:0] = warnings
    html = write_mining_report(out_dir / REPORT_NAME)
    if as_json:
        click.echo(json.dumps(report.to_dict(), indent=1))
        return
    for line in report.warnings:
        click.echo(f"warning: {line}", err=True)
    for skip in report.skipped[:SHOWN_SKIPS]:
        click.echo(f"skipped: {skip['scenario_id']}: {skip['reason']}", err=True)
    if len(report.skipped) > SHOWN_SKIPS:
        click.echo(f"... {len(report.skipped) - SHOWN_SKIPS} more skipped in {REPORT_NAME}",
                   err=True)
    by_class = ", ".join(f"{c} {n}" for c, n in sorted(report.written.items())) or "none"
    rate = report.vehicle_hours / report.seconds if report.seconds else 0.0
    click.echo(f"mine: {sum(report.written.values())} records ({by_class}) from "
               f"{len(report.files)} files, {report.vehicle_hours:.2f} vehicle-hours in "
               f"{report.seconds:.1f} s ({rate:.2f} vehicle-hours/s), "
               f"{len(report.skipped)} skipped -> {out_dir} (open {html})")

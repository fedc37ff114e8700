"""``scenweave mine DATA --out DIR``: every manoeuvre in public trajectory data, as records."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import class_codes, json_option
from scenweave.commands.where_option import where_option
from scenweave.console import counted_lines
from scenweave.progress import progress
from scenweave.schemas.scenario_folder import IN_SITU_DIR, IN_SITU_REPORT_NAME, MINING_REPORT_NAME


@click.command("mine")
@click.argument("data", type=click.Path(exists=True, path_type=Path))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for highway/<CLASS>.json, mining_report.json and .html.")
@click.option("--thresholds", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Detection thresholds JSON (default: mining/thresholds.json).")
@click.option("--classes", callback=class_codes, help="Only these classes, e.g. BRAKE,CINF.")
@click.option("--in-situ", "in_situ", is_flag=True,
              help="Also write each record's in-situ scenario (its recorded road and every "
                   "recorded vehicle, played in esmini and judged) into OUT/in_situ/.")
@click.option("--context-s", type=click.FloatRange(min=0.0), default=3.0, show_default=True,
              help="With --in-situ: seconds of recording kept before and after each event.")
@where_option()
@json_option("the mining report")
def mine(data: Path, out_dir: Path, thresholds: Path | None, classes: tuple[str, ...],
         in_situ: bool, context_s: float, where: Any, as_json: bool) -> None:
    """Read CommonRoad XML, NGSIM CSV or highD files (a file or a folder), find the
    manoeuvres of the MOOVE classes in them and write each as a canonical record (with
    --where, only those it matches). Exit status 1 when an event found was refused or no
    record was written (a --where that matches none included)."""
    from scenweave.mining.mine import mine_recordings
    from scenweave.mining.readers import read_recordings
    from scenweave.mining.thresholds import ThresholdsError, load_thresholds
    from scenweave.presentation.mining_report import write_mining_report

    warnings: list[str] = []
    try:
        limits = load_thresholds(thresholds, warnings)
    except ThresholdsError as err:
        raise click.BadParameter(str(err), param_hint="--thresholds") from err
    report = mine_recordings(progress(read_recordings(data), desc="mining"), out_dir, limits,
                             classes, where=where)
    report.warnings[:0] = warnings
    html = write_mining_report(out_dir / MINING_REPORT_NAME)
    batch = _in_situ(out_dir, context_s) if in_situ and any(report.written.values()) else None
    if as_json:
        click.echo(json.dumps(report.to_dict() | ({"in_situ": batch.to_dict()} if batch else {}),
                              indent=1))
    else:
        _tell(report, out_dir, html)
        if where is not None:
            _tell_where(report, where)
        if batch is not None:
            _tell_in_situ(batch, out_dir)
    # an event found but refused counts as a problem, as does an input nothing was read from
    exit_codes.finish(not sum(report.written.values()) or bool(report.skipped)
                      or bool(batch and batch.refused))


def _in_situ(out_dir: Path, context_s: float) -> Any:
    """Every written record's in-situ scenario in OUT/in_situ/ (roads cached in
    $SCENWEAVE_HOME/roads)."""
    from scenweave.agent.home import home
    from scenweave.ingest import load_records
    from scenweave.mining.in_situ import InSituSettings, write_in_situ_records

    records = progress(list(load_records(out_dir)), desc="in situ")
    return write_in_situ_records(records, out_dir / IN_SITU_DIR, home() / "roads",
                                 InSituSettings(context_s=context_s))


def _tell_in_situ(batch: Any, out_dir: Path) -> None:
    passed = sum(1 for r in batch.written if r.verdict is not None and r.verdict.passed)
    click.echo(f"in situ: {len(batch.written)} scenarios ({passed} played as recorded), "
               f"{len(batch.refused)} refused -> {out_dir / IN_SITU_DIR}")
    if batch.refused:
        for line in counted_lines(f"refused in situ: {len(batch.refused)}", batch.refused,
                                  str(out_dir / IN_SITU_DIR / IN_SITU_REPORT_NAME)):
            click.echo(line, err=True)


def _tell_where(report: Any, where: Any) -> None:
    """How many playable records the filter kept, or that it kept none."""
    left_out = sum(report.not_matching.values())
    kept = sum(report.written.values())
    if not kept:
        from scenweave.mining.where import NothingMatched

        click.echo(str(NothingMatched(where.text, left_out)), err=True)
    else:
        click.echo(f"--where {where.text!r}: {kept} of {kept + left_out} records match")


def _tell(report: Any, out_dir: Path, html: Path) -> None:
    """The summary line, then what was refused and the warnings, a few of each."""
    by_class = ", ".join(f"{c} {n}" for c, n in sorted(report.written.items())) or "none"
    rate = report.vehicle_hours / report.seconds if report.seconds else 0.0
    click.echo(f"mine: {sum(report.written.values())} records ({by_class}) from "
               f"{len(report.files)} files, {report.vehicle_hours:.2f} vehicle-hours in "
               f"{report.seconds:.1f} s ({rate:.2f} vehicle-hours/s), "
               f"{len(report.skipped)} refused -> {out_dir} (open {html})")
    where = str(out_dir / MINING_REPORT_NAME)
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

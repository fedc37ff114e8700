"""``scenweave validate FILE...``: XSD 1.0, auto-fix, structural/semantic checks, fidelity."""

from __future__ import annotations

import json
from pathlib import Path

import click

from scenweave import exit_codes
from scenweave.commands.agent_options import json_option
from scenweave.judge import validate_xosc


@click.command("validate")
@click.argument("files", nargs=-1, required=True,
                type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--params", "params_file", type=click.Path(exists=True, dir_okay=False,
                                                          path_type=Path),
              help="params.json the scenario was made from: also checks parameter fidelity.")
@click.option("--no-fix", is_flag=True, help="Report instead of applying the auto-fix rules.")
@json_option("one result per file")
def validate(files: tuple[Path, ...], params_file: Path | None, no_fix: bool,
             as_json: bool) -> None:
    """Validate .xosc files; exit status 1 if any is invalid."""
    params = json.loads(params_file.read_text(encoding="utf-8")) if params_file else None
    results = {path: validate_xosc(path, params, fix=not no_fix) for path in files}
    if as_json:
        click.echo(json.dumps([{"file": str(p), **r.to_dict()} for p, r in results.items()],
                              indent=1))
    else:
        for path, result in results.items():
            state = "valid" if result.valid else "INVALID"
            fixes = f" (fixed: {', '.join(result.fixes_applied)})" if result.fixes_applied else ""
            click.echo(f"{path}: {state}, {result.domain}{fixes}")
            for finding in result.errors:
                where = f"line {finding.line}: " if finding.line else ""
                click.echo(f"  {finding.severity} {finding.code}: {where}{finding.message}")
        invalid = sum(not r.valid for r in results.values())
        click.echo(f"validate: {len(results) - invalid} valid, {invalid} invalid")
    exit_codes.finish(any(not r.valid for r in results.values()))

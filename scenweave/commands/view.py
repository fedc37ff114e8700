"""``scenweave view [RUN_DIR ...] [--port 8765] [--static OUT]``: watch every scenario.

A local web app on loopback (``scenweave.viewer``): the runs and their scenarios, and for each
scenario its replay animated on the map with charts on the same clock, the agent's attempts,
its variants and its files. ``--static OUT`` writes the same page as files to share instead.
"""

from __future__ import annotations

from pathlib import Path

import click

DEFAULT_RUNS = Path("runs")


@click.command("view")
@click.argument("paths", nargs=-1, type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--port", default=8765, show_default=True, type=click.IntRange(1, 65535),
              help="Port on 127.0.0.1 to serve the viewer on.")
@click.option("--static", "static_out", type=click.Path(file_okay=False, path_type=Path),
              help="Write the viewer as static files into this folder instead of serving it "
                   "(open OUT/index.html from disk or any web server).")
def view(paths: tuple[Path, ...], port: int, static_out: Path | None) -> None:
    """Watch the scenarios of run folders (default: ./runs): replay, charts, trace, files."""
    from scenweave.viewer import catalog

    folders = list(paths) or [DEFAULT_RUNS]
    if not any(catalog.find_runs([p]) for p in folders if p.is_dir()):
        raise click.UsageError("no run folder found in " + ", ".join(map(str, folders))
                               + " (give RUN_DIR or the folder holding runs)")
    if static_out is not None:
        from scenweave.viewer.static_site import write_static_site

        counts = write_static_site(folders, static_out)
        click.echo(f"view: {counts['runs']} runs, {counts['scenarios']} scenarios -> "
                   f"{static_out / 'index.html'}")
        return
    from scenweave.viewer.app import HOST, serve

    click.echo(f"view: http://{HOST}:{port}/ (Ctrl-C to stop)")
    serve(folders, port)

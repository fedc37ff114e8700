"""``scenweave spawn-db``: build the spawn database from a map, picture it, mark it reviewed."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import click

from scenweave.commands.agent_options import map_option
from scenweave.roads import MapRef, road_network
from scenweave.runner import spawn_db_cache
from scenweave.spawn_db import (
    DEFAULT_DB_PATH,
    build_database,
    carry_reviews,
    database_path,
    load_database,
    mark_reviewed,
    spawn_database,
    write_database,
)

FILE = click.Path(dir_okay=False, path_type=Path)


@click.group("spawn-db")
def spawn_db() -> None:
    """The spawn-point database: build it from an OpenDRIVE map, show it, review it."""


@spawn_db.command("build")
@map_option()
@click.option("--out", "out_path", type=FILE,
              help="Database JSON to write [default: spawn_db/Town04.json for the bundled "
                   "Town04, else the map's cached database in $SCENWEAVE_HOME].")
@click.option("--keep-reviews/--no-keep-reviews", default=True, show_default=True,
              help="Carry manually_reviewed flags over from an existing --out file (same "
                   "road, lane and s).")
def build(map_ref: MapRef, out_path: Path | None, keep_reviews: bool) -> None:
    """Generate the spawn database of the map (deterministic: same map, same bytes)."""
    out_path = out_path or database_path(map_ref, spawn_db_cache())
    database = build_database(map_ref.path)
    kept = (carry_reviews(database, load_database(out_path))
            if keep_reviews and out_path.exists() else 0)
    write_database(database, out_path)
    counts = Counter(entry["context"] for entry in database["spawn_points"])
    summary = ", ".join(f"{n} {context}" for context, n in sorted(counts.items()))
    click.echo(f"spawn-db build: {len(database['spawn_points'])} spawn points ({summary}), "
               f"{kept} reviews kept, from {map_ref.path.name} -> {out_path}")


@spawn_db.command("show")
@click.option("--db", "db_path", type=FILE,
              help="Database JSON [default: the map's, built on first use].")
@map_option()
@click.option("--out", "out_path", type=FILE, default=Path("spawn_points.png"),
              show_default=True, help="PNG to write.")
@click.option("--json", "as_json", is_flag=True,
              help="Also print the spawn points as JSON lines (id, context, place, review).")
def show(db_path: Path | None, map_ref: MapRef, out_path: Path, as_json: bool) -> None:
    """Draw the map and its spawn points (by context and priority) into a PNG for review
    (needs the optional matplotlib: ``pip install 'scenweave[plot]'``)."""
    try:
        from scenweave.spawn_db.map_plot import plot_spawn_points
    except ImportError as err:  # the one drawing that needs matplotlib: an extra, not a must
        raise click.ClickException(f"spawn-db show draws with matplotlib, which is not "
                                   f"installed ({err}): pip install 'scenweave[plot]'") from err

    database = load_database(db_path or spawn_database(map_ref, spawn_db_cache()))
    plot_spawn_points(road_network(map_ref.path), database, out_path)
    entries = database["spawn_points"]
    if as_json:
        for entry in entries:
            click.echo(json.dumps({
                "spawn_id": entry["spawn_id"], "context": entry["context"],
                **{k: entry["geometry"][k] for k in ("road_id", "lane_id", "s")},
                "suitable_for": entry["annotations"]["suitable_for"],
                "priority": entry["annotations"]["priority"],
                "manually_reviewed": entry["annotations"]["manually_reviewed"]}))
    reviewed = sum(e["annotations"]["manually_reviewed"] for e in entries)
    click.echo(f"spawn-db show: {len(entries)} spawn points, {reviewed} reviewed -> {out_path}")


@spawn_db.command("review")
@click.argument("spawn_ids", nargs=-1, required=True)
@click.option("--db", "db_path", type=FILE, default=DEFAULT_DB_PATH, show_default=True)
@click.option("--undo", is_flag=True, help="Mark the entries as not reviewed instead.")
def review(spawn_ids: tuple[str, ...], db_path: Path, undo: bool) -> None:
    """Mark spawn points as manually reviewed: ids or ranges, e.g. ``12 40-45``."""
    ids = _parse_ids(spawn_ids)
    changed = mark_reviewed(db_path, ids, reviewed=not undo)
    state = "not reviewed" if undo else "reviewed"
    click.echo(f"spawn-db review: {changed} of {len(ids)} spawn points now {state} in {db_path}")


def _parse_ids(values: tuple[str, ...]) -> list[int]:
    ids: list[int] = []
    for value in values:
        first, _, last = value.partition("-")
        try:
            low, high = int(first), int(last or first)
        except ValueError:
            raise click.BadParameter(f"{value!r} is not a spawn id or a range like 12-20",
                                     param_hint="SPAWN_IDS") from None
        if high < low:
            raise click.BadParameter(f"range {value!r} runs backwards", param_hint="SPAWN_IDS")
        ids.extend(range(low, high + 1))
    return ids

"""``scenweave spawn-db build | show | review`` as a user runs them."""

from __future__ import annotations

import json
import shutil

from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.spawn_db import DEFAULT_DB_PATH, load_database, mark_reviewed


def test_build_keeps_reviews_and_review_marks_ranges(tmp_path):
    db = tmp_path / "Town04.json"
    shutil.copy(DEFAULT_DB_PATH, db)
    mark_reviewed(db, [e["spawn_id"] for e in load_database(db)["spawn_points"]], False)
    runner = CliRunner()
    marked = runner.invoke(cli, ["spawn-db", "review", "3", "10-12", "--db", str(db)])
    assert marked.exit_code == 0, marked.output
    assert "4 of 4 spawn points now reviewed" in marked.output
    built = runner.invoke(cli, ["spawn-db", "build", "--out", str(db)])
    assert built.exit_code == 0, built.output
    highway = sum(e["context"] == "highway" for e in load_database(DEFAULT_DB_PATH)["spawn_points"])
    assert "4 reviews kept" in built.output and f"{highway} highway" in built.output
    reviewed = [e["spawn_id"] for e in load_database(db)["spawn_points"]
                if e["annotations"]["manually_reviewed"]]
    assert reviewed == [3, 10, 11, 12]
    undone = runner.invoke(cli, ["spawn-db", "review", "--undo", "11", "--db", str(db)])
    assert "1 of 1 spawn points now not reviewed" in undone.output


def test_review_rejects_bad_ids(tmp_path):
    db = tmp_path / "Town04.json"
    shutil.copy(DEFAULT_DB_PATH, db)
    result = CliRunner().invoke(cli, ["spawn-db", "review", "12-x", "--db", str(db)])
    assert result.exit_code != 0 and "not a spawn id or a range" in result.output


def test_show_writes_a_png_and_lists_as_json(tmp_path):
    out = tmp_path / "spawns.png"
    result = CliRunner().invoke(cli, ["spawn-db", "show", "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    data = out.read_bytes()
    assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 50_000
    lines = result.output.strip().splitlines()
    first = json.loads(lines[0])
    assert first["spawn_id"] == 1 and first["context"] in ("highway", "urban")
    entries = load_database(DEFAULT_DB_PATH)["spawn_points"]
    total = len(entries)
    reviewed = sum(e["annotations"]["manually_reviewed"] for e in entries)
    assert lines[-1].startswith(f"spawn-db show: {total} spawn points, {reviewed} reviewed")
    assert len(lines) == total + 1


def test_show_without_matplotlib_names_the_extra_to_install(tmp_path, monkeypatch):
    """matplotlib is optional (``scenweave[plot]``): without it, show says what to install
    and writes nothing; the other commands do not need it."""
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    monkeypatch.delitem(sys.modules, "scenweave.spawn_db.map_plot", raising=False)
    out = tmp_path / "spawns.png"
    result = CliRunner().invoke(cli, ["spawn-db", "show", "--out", str(out)])
    assert result.exit_code == 1 and "pip install 'scenweave[plot]'" in result.output
    assert not out.exists()

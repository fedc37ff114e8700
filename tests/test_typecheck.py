"""scripts/typecheck.py: the link tree it gives mypy is the installed namespace, made from
pyproject's package-dir table, and mypy reads the linked folders as ``scenweave.<folder>``."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _typecheck_module():
    spec = importlib.util.spec_from_file_location("typecheck", ROOT / "scripts" / "typecheck.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


typecheck = _typecheck_module()


def _project(root: Path, bad_line: str = "") -> Path:
    """A tiny checkout: a shell folder and one top-level folder installed as a subpackage."""
    root.mkdir()
    (root / "pyproject.toml").write_text(
        '[tool.setuptools.package-dir]\n"scenweave" = "scenweave"\n"scenweave.road" = "road"\n',
        encoding="utf-8")
    (root / "scenweave").mkdir()
    (root / "scenweave" / "__init__.py").write_text("", encoding="utf-8")
    (root / "scenweave" / "cli.py").write_text(
        "from scenweave.road.lanes import width\n\nW: float = width()\n", encoding="utf-8")
    (root / "road").mkdir()
    (root / "road" / "__init__.py").write_text("", encoding="utf-8")
    (root / "road" / "lanes.py").write_text(
        f"def width() -> float:\n    return 3.5\n{bad_line}", encoding="utf-8")
    return root


def test_the_tree_links_the_shell_and_each_folder_as_its_subpackage(tmp_path):
    root = _project(tmp_path / "repo")
    tree = typecheck.build_tree(tmp_path / "tree", root)
    package = tree / "scenweave"
    assert sorted(p.name for p in package.iterdir()) == ["__init__.py", "cli.py", "road"]
    assert (package / "road").resolve() == (root / "road").resolve()
    assert (package / "cli.py").resolve() == (root / "scenweave" / "cli.py").resolve()
    # made again from the table on every run: a removed module leaves no stale link
    (root / "scenweave" / "cli.py").unlink()
    typecheck.build_tree(tmp_path / "tree", root)
    assert not (package / "cli.py").exists()


def test_the_real_table_links_every_folder():
    table = typecheck.package_dirs()
    assert table["scenweave"] == "scenweave"
    assert all((ROOT / folder / "__init__.py").is_file() for folder in table.values())


def test_mypy_reads_a_linked_folder_as_the_subpackage_and_names_the_repository_path(tmp_path):
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy is not installed (the dev extra has it)")
    root = _project(tmp_path / "repo", bad_line='\nLANES: int = "two"\n')
    tree = typecheck.build_tree(tmp_path / "tree", root)
    done = subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", "-p", "scenweave"],
                          cwd=tree, capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, done.stdout + done.stderr
    errors = [typecheck.repository_paths(line, typecheck.package_dirs(root / "pyproject.toml"))
              for line in done.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 1 and errors[0].startswith("road/lanes.py:4: error:"), errors


def test_paths_in_messages_are_the_repositorys():
    table = {"scenweave": "scenweave", "scenweave.maneuvers": "maneuvers"}
    assert (typecheck.repository_paths("scenweave/maneuvers/cut.py:3: error: x", table)
            == "maneuvers/cut.py:3: error: x")
    assert (typecheck.repository_paths("scenweave/cli.py:1: error: x", table)
            == "scenweave/cli.py:1: error: x")

"""Type-check ScenWeave with mypy, as CI does (``scripts/test.sh``):

    .venv/bin/python scripts/typecheck.py              # every package
    .venv/bin/python scripts/typecheck.py -p scenweave.maneuvers --strict   # mypy's own options

Why a link tree: the repository keeps its folders at the top (``maneuvers/``, ``spawn_db/``...)
and pyproject's ``[tool.setuptools.package-dir]`` installs them as ``scenweave.maneuvers``...
through the import hook of a PEP 660 editable install, which a static checker does not run.
mypy has no option that maps a package name onto another folder (``mypy_path`` and
``explicit_package_bases`` only name the roots that paths are read from, so ``maneuvers/``
would be a top-level ``maneuvers``); setuptools' ``editable_mode=strict`` would link a tree for
the whole venv, but file by file, so a new module would not import until the next install.
Here the tree links whole folders (a new module is checked at once) and lives in
``build/typecheck/``; it is made from the package-dir table on every run, so the table stays
the one definition. mypy's settings are pyproject's ``[tool.mypy]``; paths in its messages are
the repository's (``maneuvers/brake.py``, not the link's ``scenweave/maneuvers/brake.py``).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREE = ROOT / "build" / "typecheck"
NAMESPACE = "scenweave"


def package_dirs(pyproject: Path = ROOT / "pyproject.toml") -> dict[str, str]:
    """pyproject's ``package-dir`` table: import name -> repository folder."""
    with pyproject.open("rb") as file:
        table: dict[str, str] = tomllib.load(file)["tool"]["setuptools"]["package-dir"]
    return table


def build_tree(tree: Path = TREE, root: Path = ROOT) -> Path:
    """Link ``tree/scenweave`` as pip installs it: the shell folder's entries, and each other
    folder as the subpackage the table names. Returns the folder to run mypy in."""
    package = tree / NAMESPACE
    if package.is_symlink() or package.is_file():
        package.unlink()
    elif package.exists():
        shutil.rmtree(package)
    package.mkdir(parents=True)
    table = package_dirs(root / "pyproject.toml")
    for entry in sorted((root / table[NAMESPACE]).iterdir()):
        if entry.name != "__pycache__":
            (package / entry.name).symlink_to(entry)
    for name, folder in table.items():
        head, _, sub = name.partition(".")
        if head != NAMESPACE or "." in sub:
            raise SystemExit(f"typecheck: pyproject package-dir {name!r}: only "
                             f"{NAMESPACE}.<folder> entries can be linked")
        if sub:
            (package / sub).symlink_to(root / folder, target_is_directory=True)
    return tree


def repository_paths(line: str, table: dict[str, str]) -> str:
    """``scenweave/maneuvers/brake.py:3: ...`` -> ``maneuvers/brake.py:3: ...``."""
    for name, folder in sorted(table.items(), key=lambda item: -len(item[0])):
        linked = name.replace(".", "/") + "/"
        if line.startswith(linked):
            return folder + "/" + line.removeprefix(linked)
    return line


def main(argv: list[str]) -> int:
    tree = build_tree()
    targets = argv or ["-p", NAMESPACE]
    command = [sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
               *targets]
    done = subprocess.run(command, cwd=tree, capture_output=True, text=True,
                          env={**os.environ, "MYPY_FORCE_COLOR": "0"})
    table = package_dirs()
    for line in done.stdout.splitlines():
        print(repository_paths(line, table))
    sys.stderr.write(done.stderr)
    return done.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

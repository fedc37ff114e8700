"""One import namespace: installed, ScenWeave is the single top-level package ``scenweave``.

The repository keeps its top-level folders (``agent/``, ``corpus/``, ...); pyproject maps each
to ``scenweave.<folder>``. A plain ``pip install .`` must not put generic names such as
``schemas`` into site-packages, where scenariogeneration already ships a ``schemas/`` folder.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from tests.test_layering import FOLDERS, ROOT

CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def _installed_name(folder: Path) -> str:
    parts = folder.relative_to(ROOT).parts
    return ".".join(parts if parts[0] == "scenweave" else ("scenweave", *parts))


def test_every_package_folder_is_listed_for_installation():
    on_disk = {_installed_name(init.parent) for top in FOLDERS
               for init in (ROOT / top).rglob("__init__.py")}
    assert on_disk <= set(CONFIG["packages"]), on_disk - set(CONFIG["packages"])


def test_every_folder_maps_under_scenweave():
    assert CONFIG["package-dir"] == {
        ("scenweave" if top == "scenweave" else f"scenweave.{top}"): top for top in FOLDERS}


@pytest.mark.slow
def test_the_wheel_holds_only_the_scenweave_namespace(tmp_path):
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
                            "-w", str(tmp_path), str(ROOT)],
                           capture_output=True, text=True, timeout=300, check=False)
    assert built.returncode == 0, built.stderr
    (wheel,) = tmp_path.glob("scenweave-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    tops = {name.split("/")[0] for name in names}
    assert tops == {"scenweave", next(t for t in tops if t.endswith(".dist-info"))}, tops
    for expected in ("scenweave/agent/graph.py", "scenweave/scenario_lib/builder.py",
                     "scenweave/corpus/gen_hw_brake.py",
                     "scenweave/schemas/highway_layouts.json", "scenweave/spawn_db/Town04.json",
                     "scenweave/roads/maps/Town04.xodr", "scenweave/roads/maps/Town06.xodr",
                     "scenweave/roads/maps/Town10HD.xodr",
                     "scenweave/roads/maps/LICENSE-CARLA-MIT.txt",
                     "scenweave/presentation/templates/report.html"):
        assert expected in names

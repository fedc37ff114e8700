"""Builds ScenWeave with its viewer's front-end libraries; everything else is in pyproject.toml.

The viewer's vendored files (uPlot and its licence, ``viewer/static/vendor/``) are not in the
repository: ``scripts/setup.d/50-viewer.sh`` installs them from the npm registry as
``viewer/package-lock.json`` pins them. A wheel built from a clone where setup never ran would
lack them and ``scenweave view`` would stop, so building one runs that script first (it needs
npm, and installs Debian's when it can). An editable install leaves it to setup.
"""

import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
VENDOR = ROOT / "viewer" / "static" / "vendor"
#: the files scenweave view serves from the vendor folder (viewer.app.check_assets)
VENDORED = ("uPlot.iife.min.js", "uPlot.min.css", "LICENSE")


class BuildPyWithViewer(build_py):
    """``build_py`` that vendors the viewer's libraries first when they are missing."""

    def run(self) -> None:
        if not getattr(self, "editable_mode", False) and \
                not all((VENDOR / name).is_file() for name in VENDORED):
            subprocess.run(["bash", str(ROOT / "scripts" / "setup.d" / "50-viewer.sh")],
                           check=True)
        super().run()


setup(cmdclass={"build_py": BuildPyWithViewer})

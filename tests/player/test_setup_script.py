"""``scripts/setup.d/10-esmini.sh``: which esmini setup uses, run against temporary folders.

The script is copied into a temporary repository layout (so the workplace copy
``../shared/esmini`` is whatever the test puts there), installs into a temporary prefix with
a temporary build cache, and its release URL points at loopback: a closed port, or a small
HTTP server serving a release-shaped zip. No test builds esmini (that takes minutes).
"""

from __future__ import annotations

import functools
import hashlib
import http.server
import os
import socket
import subprocess
import sys
import tarfile
import threading
import time
import zipfile
from pathlib import Path

import pytest

from scenweave.player import locate

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "setup.d" / "10-esmini.sh"
REAL_BIN = locate.WORKPLACE_HOME / "bin"
RELEASE = "esmini-bin_Linux.zip"

pytestmark = pytest.mark.skipif(not (REAL_BIN / locate.LIBRARY).is_file(),
                                reason="needs a working esmini library (../shared/esmini)")


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


class Layout:
    """A temporary repository holding the script, with its own prefix, cache and release URL."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.repo = root / "repo"
        (self.repo / "scripts" / "setup.d").mkdir(parents=True)
        self.script = self.repo / "scripts" / "setup.d" / SCRIPT.name
        self.script.write_bytes(SCRIPT.read_bytes())
        self.prefix = root / "opt" / "esmini"
        self.cache = root / "cache"
        self.workplace = root / "shared" / "esmini"
        (root / "tmp").mkdir()
        self.release_url = f"http://127.0.0.1:{closed_port()}/{RELEASE}"

    def run(self, **env: str) -> tuple[list[str], float]:
        """The script's output lines and its wall time; it must succeed."""
        base = {k: v for k, v in os.environ.items()
                if k not in ("ESMINI_HOME", "ESMINI_SOURCE_ARCHIVE")}
        base.update(SCENWEAVE_ESMINI_PREFIX=str(self.prefix),
                    SCENWEAVE_ESMINI_CACHE=str(self.cache), ESMINI_RELEASE_URL=self.release_url,
                    TMPDIR=str(self.root / "tmp"),
                    # the copy has no .venv: its `python3` is the one running the tests
                    PATH=f"{Path(sys.executable).parent}:{os.environ['PATH']}")
        base.update(env)
        started = time.monotonic()
        done = subprocess.run(["bash", str(self.script)], env=base, capture_output=True,
                              text=True, timeout=120)
        took = time.monotonic() - started
        assert done.returncode == 0, done.stdout + done.stderr
        assert done.stderr == "", done.stderr
        return done.stdout.splitlines(), took


def esmini_home(folder: Path) -> Path:
    """A home whose bin/ links to the real esmini files."""
    (folder / "bin").mkdir(parents=True)
    for name in ("libesminiLib.so", "libesminiRMLib.so", "esmini"):
        (folder / "bin" / name).symlink_to(REAL_BIN / name)
    return folder


@pytest.fixture
def layout(tmp_path) -> Layout:
    return Layout(tmp_path)


def test_esmini_home_is_used_first_in_one_line(layout):
    home = esmini_home(layout.root / "mine")
    esmini_home(layout.workplace)
    lines, _ = layout.run(ESMINI_HOME=str(home))
    assert len(lines) == 1
    assert lines[0].startswith(f"esmini: using ESMINI_HOME={home} (v3.6.0")
    assert not layout.prefix.exists()


def test_a_bogus_esmini_home_falls_through_to_the_workplace_copy(layout):
    esmini_home(layout.workplace)
    lines, _ = layout.run(ESMINI_HOME=str(layout.root / "bogus"))
    assert len(lines) == 1
    assert lines[0].startswith(f"esmini: using the workplace copy {layout.workplace} (v3.6.0")
    assert "ESMINI_HOME skipped: no " in lines[0]


def test_a_library_that_does_not_load_is_not_used(layout):
    home = layout.root / "broken"
    (home / "bin").mkdir(parents=True)
    (home / "bin" / "libesminiLib.so").write_text("not a library")
    esmini_home(layout.workplace)
    lines, _ = layout.run(ESMINI_HOME=str(home))
    assert lines[0].startswith("esmini: using the workplace copy")
    assert "does not load" in lines[0]


def test_nothing_anywhere_and_no_network_ends_quickly_without_failing(layout):
    lines, took = layout.run(ESMINI_HOME=str(layout.root / "bogus"))
    assert len(lines) == 1
    line = lines[0]
    assert line.startswith("esmini: not installed, replay will be unavailable")
    for tried in ("ESMINI_HOME: no ", "no workplace copy", "ESMINI_SOURCE_ARCHIVE unset",
                  f"release archive {layout.release_url}: unreachable"):
        assert tried in line
    assert took < 20
    assert not layout.prefix.exists()


def fake_archive(layout: Layout) -> tuple[Path, str]:
    """A small source archive and its sha256 (the build-cache key)."""
    src = layout.root / "esmini-src"
    src.mkdir()
    (src / "CMakeLists.txt").write_text("project(not_esmini)\n")
    archive = layout.root / "esmini-test-src.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(src, arcname="esmini-src")
    return archive, hashlib.sha256(archive.read_bytes()).hexdigest()


def test_a_cached_source_build_is_installed_without_rebuilding(layout):
    archive, sha = fake_archive(layout)
    esmini_home(layout.cache / sha)       # what an earlier build of this archive left
    lines, _ = layout.run(ESMINI_SOURCE_ARCHIVE=str(archive))
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"esmini: using a build of ESMINI_SOURCE_ARCHIVE={archive} in "
                               f"{layout.prefix} (v3.6.0")
    assert f"from the build cache {layout.cache / sha}" in lines[0]
    assert (layout.prefix / "bin" / "libesminiLib.so").is_file()
    stamp = (layout.prefix / ".scenweave-esmini").read_text()
    assert stamp == f"source-archive sha256={sha} {archive.name}\n"

    again, took = layout.run(ESMINI_SOURCE_ARCHIVE=str(archive))
    assert again[0].endswith("; already installed)")
    assert took < 10
    # without the archive, a later setup keeps using what is installed
    later, _ = layout.run()
    assert later[0].startswith(f"esmini: using the earlier install in {layout.prefix} (v3.6.0")


def test_a_source_archive_that_does_not_build_falls_through_and_says_why(layout):
    archive = layout.root / "broken-src.tar.gz"
    archive.write_text("not a tar archive")
    lines, _ = layout.run(ESMINI_SOURCE_ARCHIVE=str(archive))
    assert lines[0].startswith("esmini: building broken-src.tar.gz")
    assert lines[-1].startswith("esmini: not installed, replay will be unavailable")
    assert "ESMINI_SOURCE_ARCHIVE: build failed: tar: " in lines[-1]
    assert not any(layout.cache.glob("????*/bin"))   # no cache entry for a failed build
    assert not layout.prefix.exists()


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args: object) -> None:
        pass


def test_the_release_archive_is_fetched_unpacked_and_installed(layout):
    served = layout.root / "served"
    served.mkdir()
    with zipfile.ZipFile(served / RELEASE, "w") as release:   # laid out like esmini's release
        for name in ("libesminiLib.so", "libesminiRMLib.so", "esmini"):
            release.write(REAL_BIN / name, f"esmini/bin/{name}")
        release.writestr("esmini/EnvironmentSimulator/Libraries/esminiLib/esminiLib.hpp", "//\n")
    server = http.server.ThreadingHTTPServer(
        ("127.0.0.1", 0), functools.partial(QuietHandler, directory=str(served)))
    threading.Thread(target=server.serve_forever, args=(0.05,), daemon=True).start()
    try:
        layout.release_url = f"http://127.0.0.1:{server.server_address[1]}/{RELEASE}"
        lines, _ = layout.run()
    finally:
        server.shutdown()
        server.server_close()
    assert len(lines) == 1
    assert lines[0].startswith(f"esmini: using esmini's release archive {layout.release_url}, "
                               f"installed in {layout.prefix} (v3.6.0")
    assert os.access(layout.prefix / "bin" / "esmini", os.X_OK)
    assert (layout.prefix / "include" / "esminiLib.hpp").is_file()
    assert (layout.prefix / ".scenweave-esmini").read_text() == f"release {layout.release_url}\n"
    assert not list((layout.root / "tmp").iterdir())    # no download left behind

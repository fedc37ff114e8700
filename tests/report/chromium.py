"""Headless Chromium for looking at a page the way a reader does: the DOM after it rendered,
or a screenshot."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage"]


def chromium() -> str:
    """The Chromium binary; the test is skipped with the install hint where there is none."""
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    if binary is None:
        pytest.skip("chromium is not installed (Debian package chromium; scripts/setup.sh)")
    return binary


def _run(url: str, profile: Path, *extra: str) -> subprocess.CompletedProcess:
    profile.mkdir(parents=True, exist_ok=True)
    return subprocess.run([chromium(), *FLAGS, f"--user-data-dir={profile}", *extra, url],
                          capture_output=True, text=True, timeout=120, check=True)


def dump_dom(url: str, profile: Path) -> str:
    """The serialised DOM of ``url`` after Chromium loaded it."""
    return _run(url, profile, "--dump-dom").stdout


def screenshot(url: str, profile: Path, out: Path, size: str = "1200,2200") -> Path:
    """A PNG of ``url`` as Chromium draws it."""
    _run(url, profile, f"--screenshot={out}", f"--window-size={size}")
    return out

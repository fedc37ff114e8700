"""Headless Chromium for looking at a page the way a reader does: the DOM after it rendered,
or a screenshot."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import lxml.html
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


PROBE_PAGE = """<!doctype html><meta charset="utf-8">
<iframe src="{url}" style="width:1200px;height:900px"></iframe><pre id="seen"></pre>
<script>
window.addEventListener("load", () => {{
  const doc = document.querySelector("iframe").contentDocument;
  document.getElementById("seen").textContent = JSON.stringify({{
    images: [...doc.images].map(i => ({{alt: i.alt, complete: i.complete,
                                        naturalWidth: i.naturalWidth}})),
    links: [...doc.links].map(a => ({{text: a.textContent, href: a.href}})),
  }});
}});
</script>"""


def probe(url: str, profile: Path) -> dict:
    """What the browser made of the page at ``url`` (a file:// URL) once it loaded: each
    image's decoded width, each link's URL as the browser resolved it.

    The page is opened in an iframe of a probe page whose script reads it (file:// pages may
    read each other with ``--allow-file-access-from-files``), so the page itself is untouched.
    """
    page = profile.parent / f"{profile.name}-probe.html"
    page.write_text(PROBE_PAGE.format(url=url), encoding="utf-8")
    dom = _run(page.as_uri(), profile, "--allow-file-access-from-files", "--dump-dom").stdout
    [seen] = lxml.html.fromstring(dom).xpath("//pre[@id='seen']")
    if not seen.text_content().strip():
        raise AssertionError(f"the probe page did not see {url} load")
    return json.loads(seen.text_content())

"""The viewer's test run, its server on loopback and Debian's Chromium driven by Playwright.

Screenshots go to ``build/test-artifacts/viewer/`` (``$SCENWEAVE_TEST_ARTIFACTS`` overrides).
"""

from __future__ import annotations

import os
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.viewer.runs import edit_cut_in, make_run

ROOT = Path(__file__).resolve().parents[2]
#: the flags Chromium needs on these machines (root, no GPU, a closed network)
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync", "--disable-dev-shm-usage"]


@pytest.fixture(scope="session")
def artifacts() -> Path:
    folder = Path(os.environ.get("SCENWEAVE_TEST_ARTIFACTS") or ROOT / "build" / "test-artifacts")
    folder = folder / "viewer"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="session")
def viewer_runs(sample_raw, esmini, tmp_path_factory) -> dict[str, Path]:
    """The agent run (cut-in repaired on attempt 2, a red-light stop) and the hand-edited
    cut-in that fails its replay."""
    if shutil.which("bwrap") is None:
        pytest.skip("VIEWER NOT TESTED: bubblewrap is not installed (the agent run needs it)")
    tmp = tmp_path_factory.mktemp("viewer")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SCENWEAVE_HOME", str(tmp / "home"))
        run = make_run(sample_raw, tmp)
    edited = edit_cut_in(run, tmp / "hand")
    return {"run": run, "runs": run.parent, "edited": edited, "hand": edited.parent}


@pytest.fixture(scope="session")
def server(viewer_runs) -> Iterator[str]:
    """The viewer app on 127.0.0.1 (a free port) showing the run and the hand-edited copy."""
    import uvicorn

    from scenweave.viewer.app import HOST, check_assets, create_app

    try:
        check_assets()
    except RuntimeError as err:
        pytest.fail(str(err))
    app = create_app([viewer_runs["runs"], viewer_runs["hand"]])
    served = uvicorn.Server(uvicorn.Config(app, host=HOST, port=0, log_level="warning"))
    thread = threading.Thread(target=served.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not served.started:
        if time.monotonic() > deadline or not thread.is_alive():
            pytest.fail("the viewer's server did not start")
        time.sleep(0.05)
    port = served.servers[0].sockets[0].getsockname()[1]
    yield f"http://{HOST}:{port}/"
    served.should_exit = True
    thread.join(timeout=10)


@pytest.fixture(scope="session")
def browser() -> Iterator:
    binary = shutil.which("chromium")
    if binary is None:
        pytest.skip("VIEWER NOT TESTED IN A BROWSER: chromium is not installed "
                    "(Debian package chromium; scripts/setup.sh)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        launched = playwright.chromium.launch(executable_path=binary, args=CHROMIUM_FLAGS)
        yield launched
        launched.close()


@pytest.fixture
def page(browser) -> Iterator:
    context = browser.new_context(viewport={"width": 1400, "height": 1000})
    opened = context.new_page()
    errors: list[str] = []
    opened.on("pageerror", lambda err: errors.append(str(err)))
    yield opened
    context.close()
    assert errors == [], f"the page raised: {errors}"


@pytest.fixture(scope="session")
def in_situ_scene(esmini, tmp_path_factory) -> Path:
    """A scenario folder of a run with its in-situ scene, played and judged
    (``tests/viewer/in_situ_run.py``)."""
    from tests.viewer.in_situ_run import make_in_situ_run

    return make_in_situ_run(tmp_path_factory.mktemp("in_situ"))

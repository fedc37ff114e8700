"""The viewer says, in one banner over the runs, that a run's scenarios were never played
(issue 35): not only the per-row "not played" badge."""

from __future__ import annotations

from scenweave.commands.agent_options import pipeline_settings
from scenweave.inputs import InputSelection
from scenweave.runner import run_batch

SCENARIOS = 2


def test_a_run_never_played_gets_a_banner(page, sample_raw, tmp_path, monkeypatch, artifacts):
    from scenweave.viewer.static_site import write_static_site

    empty = tmp_path / "no-esmini"
    empty.mkdir()
    for setting in ("ESMINI_HOME", "SCENWEAVE_WORKPLACE_ESMINI", "SCENWEAVE_ESMINI_PREFIX"):
        monkeypatch.setenv(setting, str(empty))
    settings = pipeline_settings(True, 5)
    assert settings.replay is None and settings.replay_not_run.startswith("no player")
    run_batch(sample_raw, tmp_path / "runs", InputSelection(limit=SCENARIOS), settings,
              run_id="unplayed")
    write_static_site([tmp_path / "runs"], tmp_path / "site")

    page.goto((tmp_path / "site" / "index.html").as_uri())
    page.wait_for_selector("tr.scenario")
    banner = page.locator("#not-played-banner")
    assert banner.is_visible()
    text = banner.inner_text()
    assert "Replay not run." in text
    assert (f"{SCENARIOS} scenarios of unplayed were never played in esmini (no player: esmini "
            "not found)") in text
    assert "scenweave doctor" in text
    assert "replay: not run" in page.locator("section.run .facts").inner_text()
    assert page.locator("tr.scenario .badge.not.played, tr.scenario .badge").filter(
        has_text="not played").count() == SCENARIOS
    page.screenshot(path=str(artifacts / "not-played-banner.png"))


def test_a_played_run_has_no_banner(page, sample_raw, tmp_path, esmini):
    from scenweave.viewer.static_site import write_static_site

    run_batch(sample_raw, tmp_path / "runs", InputSelection(limit=1), pipeline_settings(True, 5),
              run_id="played")
    write_static_site([tmp_path / "runs"], tmp_path / "site")
    page.goto((tmp_path / "site" / "index.html").as_uri())
    page.wait_for_selector("tr.scenario")
    assert page.locator("#not-played-banner").count() == 0

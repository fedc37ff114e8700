"""A scenario never played in esmini is never called ok without saying so (issue 35).

"No player" is the machine as a user's clone sees it: ``ESMINI_HOME`` names an empty folder,
and the other places ``player.locate`` searches (the workplace copy, setup's install) are
empty folders too (``SCENWEAVE_WORKPLACE_ESMINI``, ``SCENWEAVE_ESMINI_PREFIX``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.player import PlayerUnavailable, find_esmini
from scenweave.run_folder import RunFolder
from scenweave.unplayed import DOCTOR_HINT, is_unplayed, not_played_line

#: scenarios per test run: enough for two classes, few enough to stay quick
LIMIT = 3
RUN_ID = "r35"


@pytest.fixture
def no_player(tmp_path, monkeypatch) -> Path:
    """Every place the player is looked for is an empty folder."""
    empty = tmp_path / "no-esmini"
    empty.mkdir()
    for setting in ("ESMINI_HOME", "SCENWEAVE_WORKPLACE_ESMINI", "SCENWEAVE_ESMINI_PREFIX"):
        monkeypatch.setenv(setting, str(empty))
    with pytest.raises(PlayerUnavailable):
        find_esmini()
    return empty


def run_cli(*args: str) -> object:
    return CliRunner().invoke(cli, [*args], catch_exceptions=False)


def run_no_llm(sample_raw: Path, out: Path) -> object:
    return run_cli("run", str(sample_raw), "--no-llm", "--out", str(out), "--run-id", RUN_ID,
                   "--limit", str(LIMIT))


def read(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def test_a_run_without_a_player_says_its_scenarios_were_not_played(sample_raw, tmp_path,
                                                                   no_player):
    outcome = run_no_llm(sample_raw, tmp_path / "runs")
    assert outcome.exit_code == 0, outcome.output
    run = tmp_path / "runs" / RUN_ID
    summary = read(run / "summary.json")
    assert summary["counts"]["ok"] == LIMIT
    assert summary["replay"]["played"] == 0
    assert summary["replay"]["not_played"] == LIMIT
    assert summary["replay"]["not_played_because"].startswith("no player: esmini not found")
    assert read(run / "run.json")["replay_not_run"] == summary["replay"]["not_played_because"]
    lines = [line for line in outcome.stderr.splitlines() if line.startswith("replay: NOT RUN")]
    assert lines == [f"replay: NOT RUN for {LIMIT} of {LIMIT} delivered scenarios (no player: "
                     f"esmini not found): they are validated but not checked against the "
                     f"record; {DOCTOR_HINT}; then `scenweave replay {run}` plays them"]
    report = (run / "report.html").read_text(encoding="utf-8")
    assert 'id="not-played"' in report and "Replay not run" in report


def test_no_replay_asked_is_counted_but_not_printed(sample_raw, tmp_path):
    outcome = run_cli("run", str(sample_raw), "--no-llm", "--out", str(tmp_path), "--run-id",
                      RUN_ID, "--limit", "1", "--no-replay")
    assert outcome.exit_code == 0, outcome.output
    summary = read(tmp_path / RUN_ID / "summary.json")
    assert summary["replay"]["not_played_because"] == "--no-replay"
    assert summary["replay"]["not_played"] == 1
    assert "NOT RUN" not in outcome.stderr  # the user asked for it: no warning


def test_a_played_run_prints_no_such_line(sample_raw, tmp_path, esmini):
    outcome = run_no_llm(sample_raw, tmp_path)
    assert outcome.exit_code == 0, outcome.output
    summary = read(tmp_path / RUN_ID / "summary.json")
    assert summary["replay"]["played"] == LIMIT
    assert summary["replay"]["not_played"] == 0
    assert summary["replay"]["not_played_because"] is None
    assert "NOT RUN" not in outcome.stderr
    assert not_played_line(summary, tmp_path) is None


def test_a_resumed_run_with_a_player_plays_what_was_never_played(sample_raw, tmp_path,
                                                                 monkeypatch, no_player):
    runs = tmp_path / "runs"
    assert run_no_llm(sample_raw, runs).exit_code == 0
    folder = RunFolder(runs / RUN_ID)
    assert all(is_unplayed(o) for o in folder.outcomes())
    for setting in ("ESMINI_HOME", "SCENWEAVE_WORKPLACE_ESMINI", "SCENWEAVE_ESMINI_PREFIX"):
        monkeypatch.delenv(setting)
    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(f"REPLAY NOT TESTED: no esmini here ({err})")

    resumed = run_no_llm(sample_raw, runs)
    assert resumed.exit_code == 0, resumed.output
    assert f"({LIMIT} already done, {LIMIT} of them played now)" in resumed.output
    summary = read(folder.root / "summary.json")
    assert summary["replay"]["played"] == LIMIT
    assert summary["replay"]["not_played"] == 0
    assert "NOT RUN" not in resumed.stderr
    for outcome in folder.outcomes():
        assert outcome["replay"]["played"] is True
        assert (folder.scenario_dir(outcome["scenario_id"]) / "replay.json").is_file()
        assert "replayed_later_at" in outcome

    # a replay cut off before its playback was written is played again on the next resume
    first = folder.outcomes()[0]["scenario_id"]
    (folder.scenario_dir(first) / "replay.json").unlink()
    again = run_no_llm(sample_raw, runs)
    assert f"({LIMIT} already done, 1 of them played now)" in again.output
    assert (folder.scenario_dir(first) / "replay.json").is_file()


def test_replay_on_a_run_folder_plays_and_records_the_unplayed(sample_raw, tmp_path,
                                                               monkeypatch, no_player):
    runs = tmp_path / "runs"
    assert run_no_llm(sample_raw, runs).exit_code == 0
    for setting in ("ESMINI_HOME", "SCENWEAVE_WORKPLACE_ESMINI", "SCENWEAVE_ESMINI_PREFIX"):
        monkeypatch.delenv(setting)
    try:
        find_esmini()
    except PlayerUnavailable as err:
        pytest.skip(f"REPLAY NOT TESTED: no esmini here ({err})")

    played = run_cli("replay", str(runs / RUN_ID))
    assert played.exit_code == 0, played.output
    assert f"replay: {LIMIT}/{LIMIT} played as recorded" in played.output
    summary = read(runs / RUN_ID / "summary.json")
    assert (summary["replay"]["played"], summary["replay"]["not_played"]) == (LIMIT, 0)
    report = (runs / RUN_ID / "report.html").read_text(encoding="utf-8")
    assert 'id="not-played"' not in report


def test_the_collector_summary_counts_the_unplayed(sample_raw, tmp_path, no_player):
    """``collect`` and ``submit --wait`` finish a run with the collector's summary."""
    from scenweave.queue.collector import refresh_run

    assert run_no_llm(sample_raw, tmp_path).exit_code == 0
    summary = refresh_run(tmp_path / RUN_ID)
    assert summary["replay"]["not_played"] == LIMIT
    assert "NOT RUN" in not_played_line(summary, tmp_path / RUN_ID)


def test_only_delivered_scenarios_count_as_unplayed(tmp_path):
    assert is_unplayed({"status": "ok", "replay": None})
    assert is_unplayed({"status": "fallback"})
    assert not is_unplayed({"status": "failed", "replay": None})
    played = {"status": "repaired", "replay": {"played": True, "passed": True, "codes": []}}
    assert not is_unplayed(played)
    assert is_unplayed(played, tmp_path)            # its replay.json is missing
    (tmp_path / "replay.json").write_text("{}")
    assert not is_unplayed(played, tmp_path)

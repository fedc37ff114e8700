"""Issue 33: the end of a batch does not grow with its scenarios. The report asks whether a
scenario's figure is current (a read and digest of its replay.json) only until each class has
the passing figures it shows, and the summary takes the outcomes this process committed from
memory."""

from __future__ import annotations

import json

from scenweave.presentation.report import replay_figure_picks
from scenweave.run_folder import RunFolder
from scenweave.schemas.scenario_folder import STATUS_NAME


def _passing(code: str, count: int) -> list[dict]:
    return [{"scenario_id": f"{code}_{i}", "maneuver_class": code,
             "replay": {"played": True, "passed": True, "codes": []}} for i in range(count)]


def test_the_picks_ask_whether_drawn_only_until_a_class_has_its_figure():
    replayed = _passing("A", 500) + _passing("B", 500)
    asked: list[str] = []

    def drawn(outcome: dict) -> bool:
        asked.append(outcome["scenario_id"])
        return outcome["scenario_id"] in {"A_7", "B_0"}

    picks = replay_figure_picks(replayed, passing_per_class=1, drawn=drawn)
    assert [o["scenario_id"] for o in picks] == ["A_7", "B_0"]
    assert asked == [f"A_{i}" for i in range(8)] + ["B_0"]


def test_the_picks_take_the_first_ones_in_order_when_too_few_are_drawn():
    replayed = _passing("A", 6)
    picks = replay_figure_picks(replayed, passing_per_class=3,
                                drawn=lambda o: o["scenario_id"] == "A_4")
    assert [o["scenario_id"] for o in picks] == ["A_0", "A_1", "A_4"]  # in the run's order


def test_outcomes_committed_here_come_from_memory_as_their_status_json_reads(tmp_path):
    folder = RunFolder.open(tmp_path, "r")
    for name in ("b", "a"):
        folder.commit(name, folder.staging(name), {"scenario_id": name, "status": "ok",
                                                   "timings_s": (0.5, 1)})
    fresh = RunFolder(folder.root).outcomes()
    assert folder.outcomes() == fresh  # sorted by id, tuples as lists, as read back
    assert [o["scenario_id"] for o in fresh] == ["a", "b"]
    (folder.scenario_dir("a") / STATUS_NAME).write_text("damaged", encoding="utf-8")
    assert [o["scenario_id"] for o in folder.outcomes()] == ["a", "b"]  # not read again
    assert [o["scenario_id"] for o in RunFolder(folder.root).outcomes()] == ["b"]
    assert json.loads((folder.scenario_dir("b") / STATUS_NAME).read_text())["status"] == "ok"

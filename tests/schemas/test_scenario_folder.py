"""The scenario-folder contract (``schemas.scenario_folder``): the one place a run's and a
scenario folder's file names are declared, the one tolerant reader of a folder's JSON, and
the presenters drawing the judge's verdict instead of judging again."""

from __future__ import annotations

import ast
import json

from scenweave.schemas import scenario_folder as contract
from tests.test_layering import GRAPH, MODULES, ROOT, layer

#: every file and folder name the contract declares
DECLARED = {value for name, value in vars(contract).items()
            if name.isupper() and isinstance(value, str)}
#: modules that may spell a contract's name as a literal, and why
ALLOWED = {
    # the contract itself
    "scenweave.schemas.scenario_folder",
    # the sandbox job's own files (the harness runs where only scenario_lib/ is mounted, so
    # it cannot import the contract; attempt.py and settings.py speak its language)
    "scenweave.sandbox.harness", "scenweave.sandbox.attempt", "scenweave.sandbox.settings",
    # the mining report's template is named as the page it renders
    "scenweave.presentation.mining_report",
}
#: the road cache's own files (road.xodr, road.json under $SCENWEAVE_HOME/roads), which share a
#: name with the in-situ folder's road but are no file of a scenario folder
NOT_A_SCENARIO_FOLDER = {"scenweave.mining.recorded_road"}


def _literals(path) -> list[tuple[int, str]]:
    return [(node.lineno, node.value) for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and node.value in DECLARED and "." in node.value]


def test_no_module_but_the_contract_spells_a_folder_file_name():
    spelt = [f"{name}:{line} {value!r}" for name, path in MODULES.items()
             if name not in ALLOWED | NOT_A_SCENARIO_FOLDER
             for line, value in _literals(path)]
    assert spelt == []


def test_the_finder_of_spelt_names_finds_one(tmp_path):
    module = tmp_path / "m.py"
    module.write_text('STATUS = "status.json"\nNAME = "status"\n')
    assert _literals(module) == [(1, "status.json")]


def test_the_contract_imports_nothing_of_ours():
    assert {target for target in GRAPH["scenweave.schemas.scenario_folder"]} == set()


def test_the_presenters_import_neither_the_agent_nor_the_judges_checks():
    """The viewer and the replay figure draw the verdict the judge wrote; what they may use of
    the judge is its measurements on a playback (gaps along lanes, lane changes, the light)."""
    presenters = [name for name in MODULES if layer(name) == "viewer"
                  or name.startswith("scenweave.presentation.replay_")]
    reached = {(name, target) for name in presenters for target in GRAPH[name]
               if layer(target) in ("agent", "judge")}
    # scenario_doc and in_situ_doc read what a scenario file states, not a check of it
    assert {target for _, target in reached} <= {"scenweave.judge.replay",
                                                  "scenweave.judge.scenario_doc",
                                                  "scenweave.judge.in_situ_doc",
                                                  "scenweave.judge"}, reached
    for name in presenters:
        tree = ast.parse(MODULES[name].read_text())
        used = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                and node.module == "scenweave.judge.replay" for alias in node.names}
        assert used <= {"gap_series", "light_state", "lane_changes", "ROLE_ENTITIES"}, \
            (name, used)


def test_a_damaged_or_missing_file_reads_as_empty(tmp_path):
    assert contract.read_json_object(tmp_path / "missing.json") == {}
    (tmp_path / "cut.json").write_text('{"status": "ok"')
    assert contract.read_json_object(tmp_path / "cut.json") == {}
    (tmp_path / "list.json").write_text("[1, 2]")
    assert contract.read_json_object(tmp_path / "list.json") == {}
    (tmp_path / "ok.json").write_text('{"status": "ok"}')
    assert contract.read_json_object(tmp_path / "ok.json") == {"status": "ok"}


def test_json_lines_keep_the_place_of_a_bad_line(tmp_path):
    path = tmp_path / contract.TRACE_NAME
    path.write_text('{"node": "a"}\n\nnot json\n[1]\n{"node": "b"}\n')
    assert contract.read_json_lines(path) == [{"node": "a"}, None, None, {"node": "b"}]
    assert contract.read_json_lines(tmp_path / "missing.jsonl") == []


def test_an_outcome_and_a_verdict_are_read_only_when_there(tmp_path):
    assert contract.read_outcome(tmp_path) is None and contract.read_verdict(tmp_path) is None
    (tmp_path / contract.STATUS_NAME).write_text(json.dumps({"scenario_id": "BRAKE_1",
                                                              "status": "ok"}))
    (tmp_path / contract.VERDICT_NAME).write_text(json.dumps({"passed": True, "findings": []}))
    outcome, verdict = contract.read_outcome(tmp_path), contract.read_verdict(tmp_path)
    assert outcome is not None and outcome["status"] == "ok"
    assert verdict is not None and verdict["passed"]


def test_the_in_situ_folder_is_reserved_in_the_contract():
    assert contract.IN_SITU_DIR == "in_situ"
    assert {contract.XOSC_NAME, contract.ROAD_NAME, contract.VERDICT_NAME,
            contract.REPLAY_NAME} <= DECLARED
    assert ROOT.joinpath("schemas", "scenario_folder.py").is_file()

"""``scenweave run`` of mined records: beside each Town04 scenario its event in situ
(``<scenario>/in_situ/``, played and judged), or one line in ``status.json`` saying why not;
the Town04 scenario is made either way."""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave.cli import cli


def test_run_of_mined_records_writes_each_event_in_situ(esmini, data, tmp_path, monkeypatch):
    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path / "home"))
    records = tmp_path / "records"
    mined = CliRunner().invoke(cli, ["mine", str(data / "commonroad_small.xml"), "--out",
                                     str(records)])
    assert records.is_dir(), mined.output
    result = CliRunner().invoke(cli, ["run", str(records), "--no-llm", "--out",
                                      str(tmp_path / "runs"), "--run-id", "mined"])
    assert result.exit_code in (0, 1), result.output
    folders = [p for p in (tmp_path / "runs" / "mined").iterdir()
               if (p / "status.json").is_file()]
    assert folders
    written = 0
    for folder in folders:
        status = json.loads((folder / "status.json").read_text())
        assert (folder / "scenario.xosc").is_file()  # the Town04 scenario, as before
        in_situ = status["in_situ"]
        if "refused" in in_situ:
            assert "commonroad_small.xml" in in_situ["refused"]  # names the file
            assert not (folder / "in_situ").exists()
            continue
        written += 1
        assert in_situ["vehicles"] >= 1 and in_situ["passed"] is True
        for name in ("scenario.xosc", "road.xodr", "in_situ.json", "replay.json"):
            assert (folder / "in_situ" / name).is_file(), name
    assert written >= 1
    # replaying the run plays its Town04 scenarios; the in-situ ones stay as played and judged
    replayed = CliRunner().invoke(cli, ["replay", str(tmp_path / "runs" / "mined"), "--json"])
    results = json.loads(replayed.output[replayed.output.index("["):])
    assert len(results) == len(folders)
    assert not [r for r in results if "in_situ" in str(r.get("scenario"))]
    # exported for esmini: each Town04 copy with its event in situ inside its folder
    exported = tmp_path / "esmini"
    result = CliRunner().invoke(cli, ["export", str(tmp_path / "runs" / "mined"), "--for",
                                      "esmini", "--out", str(exported)])
    assert result.exit_code == 0, result.output
    for folder in folders:
        assert (exported / folder.name / "scenario.xosc").is_file()
        if (folder / "in_situ").is_dir():
            for name in ("scenario.xosc", "road.xodr", "replay.dat"):
                assert (exported / folder.name / "in_situ" / name).is_file(), name


def test_the_folders_of_mine_in_situ_are_one_run_to_view_and_export(esmini, data, tmp_path,
                                                                    monkeypatch):
    from scenweave.viewer import catalog

    monkeypatch.setenv("SCENWEAVE_HOME", str(tmp_path / "home"))
    out = tmp_path / "out"
    CliRunner().invoke(cli, ["mine", str(data / "commonroad_small.xml"), "--out", str(out),
                             "--in-situ", "--context-s", "1"])
    folders = sorted(p for p in (out / "in_situ").iterdir() if (p / "scenario.xosc").is_file())
    assert folders
    runs = catalog.find_runs([out])
    assert list(runs) == ["in_situ"]  # the folder mine --in-situ writes is one run
    rows = catalog.run_list(runs)[0]["scenarios"]
    assert [r["id"] for r in rows] == [p.name for p in folders]
    row = rows[0]
    assert row["in_situ"]["key"] == row["key"] and row["in_situ"]["vehicles"] >= 1
    scene = catalog.scenario_detail(runs, row["key"])["scene"]
    assert scene["played"] and scene["in_situ"]["judge"]["overall"]["samples"] > 0
    exported = tmp_path / "carla"
    result = CliRunner().invoke(cli, ["export", str(out / "in_situ"), "--for", "carla",
                                      "--out", str(exported)])
    assert result.exit_code == 0, result.output
    for folder in folders:  # named by their records, as mine named them
        assert (exported / folder.name / "replay_in_carla.py").is_file()

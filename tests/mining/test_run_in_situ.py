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

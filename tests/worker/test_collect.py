"""The hand-back at the submitter: parcels in a real Redis, committed into the run folder
exactly once, artefacts over the limit left behind and said so, a hostile or broken parcel
never written outside the scenario's folder."""

from __future__ import annotations

import io
import json
import tarfile
from pathlib import Path

import pytest

from scenweave.queue.collector import collect
from scenweave.queue.connection import RunKeys, connect
from scenweave.queue.handoff import Limits, ParcelError, pack, unpack
from scenweave.queue.job import hand_back
from scenweave.run_folder import RunFolder
from scenweave.schemas.scenario_folder import RUN_FILE

RUN_ID = "handback"


def _params(scenario_id: str) -> dict:
    return {"scenario_id": scenario_id, "maneuver_class": "BRAKE", "domain": "highway"}


def _made(folder: Path, scenario_id: str, big_bytes: int = 0) -> dict:
    """A scenario folder as a worker leaves it, and its outcome."""
    folder.mkdir(parents=True)
    (folder / "scenario.xosc").write_text(f"<OpenSCENARIO id='{scenario_id}'/>")
    (folder / "params.json").write_text(json.dumps(_params(scenario_id)))
    (folder / "variants" / "v01").mkdir(parents=True)
    (folder / "variants" / "v01" / "variant.json").write_text("{}")
    if big_bytes:
        (folder / "checkpoints.sqlite").write_bytes(b"x" * big_bytes)
    return {**_params(scenario_id), "status": "ok", "error_taxonomy": [], "attempts": 1}


def _spec(scenario_id: str, submission: str = "s1", limits: Limits | None = None) -> dict:
    return {"run_id": RUN_ID, "params": _params(scenario_id), "submission": submission,
            "limits": limits or Limits(), "ttl_s": 600}


@pytest.fixture
def run(tmp_path) -> RunFolder:
    folder = RunFolder.open(tmp_path / "runs", RUN_ID)
    folder.write(RUN_FILE, {"run_id": RUN_ID, "scenarios": 2})
    return folder


def test_each_parcel_is_committed_once_and_a_large_artefact_stays_behind_said_so(
        run, tmp_path, redis_url):
    connection = connect(redis_url)
    limits = Limits(file_bytes=1000, total_bytes=4000)
    outcome = _made(tmp_path / "w" / "a", "A", big_bytes=5000)
    hand_back(connection, _spec("A", limits=limits), tmp_path / "w" / "a", outcome)
    connection.sadd(RunKeys(RUN_ID).pending, "A")

    first = collect(run.root, connection)
    assert first.committed == ["A"] and first.pending == 0
    committed = run.scenario_dir("A")
    assert (committed / "variants" / "v01" / "variant.json").read_text() == "{}"
    assert not (committed / "checkpoints.sqlite").exists()
    status = json.loads((committed / "status.json").read_text())
    assert status["artefacts_left_behind"][0]["file"] == "checkpoints.sqlite"
    assert "--max-artefact-mb" in status["artefacts_left_behind"][0]["reason"]
    assert any("checkpoints.sqlite (5000 bytes) not handed back" in n for n in first.notes)
    assert json.loads((run.root / "summary.json").read_text())["total"] == 1
    assert not (run.root / "report.html").exists()  # 1 of 2 scenarios: not finished yet

    kept = "<OpenSCENARIO kept='yes'/>"
    (committed / "scenario.xosc").write_text(kept)  # a retried job hands A back again
    hand_back(connection, _spec("A"), tmp_path / "w" / "a", outcome)
    again = collect(run.root, connection)
    assert again.committed == [] and again.duplicates == 1
    assert (committed / "scenario.xosc").read_text() == kept
    assert not connection.hexists(RunKeys(RUN_ID).parcels, "A")


def test_a_resubmitted_failure_replaces_the_old_one_and_a_broken_parcel_fails_alone(
        run, tmp_path, redis_url):
    connection = connect(redis_url)
    failed = {**_made(tmp_path / "w" / "b1", "B"), "status": "failed"}
    hand_back(connection, _spec("B", submission="s1"), tmp_path / "w" / "b1", failed)
    collect(run.root, connection)
    redone = _made(tmp_path / "w" / "b2", "B")
    hand_back(connection, _spec("B", submission="s2"), tmp_path / "w" / "b2", redone)
    connection.hset(RunKeys(RUN_ID).parcels, "C", b"not a parcel")

    result = collect(run.root, connection)
    assert sorted(result.committed) == ["B", "C"] and result.complete
    assert json.loads((run.scenario_dir("B") / "status.json").read_text())["status"] == "ok"
    broken = json.loads((run.scenario_dir("C") / "status.json").read_text())
    assert broken["status"] == "failed" and broken["error_taxonomy"] == ["infrastructure"]
    assert "could not be read" in broken["error"]
    assert (run.root / "report.html").exists()


def _tar(*members: tarfile.TarInfo) -> bytes:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        for member in members:
            tar.addfile(member, io.BytesIO(b"x" * member.size) if member.isfile() else None)
    return buffer.getvalue()


@pytest.mark.parametrize("name, kind", [("../outside.txt", tarfile.REGTYPE),
                                        ("/etc/passwd", tarfile.REGTYPE),
                                        ("link.xosc", tarfile.SYMTYPE),
                                        ("fifo.json", tarfile.FIFOTYPE)])
def test_a_parcel_writes_only_plain_files_inside_its_folder(tmp_path, name, kind):
    member = tarfile.TarInfo(name)
    member.type = kind
    member.size = 3 if kind == tarfile.REGTYPE else 0
    member.linkname = "/etc/passwd" if kind == tarfile.SYMTYPE else ""
    into = tmp_path / "staging"
    into.mkdir()
    with pytest.raises(ParcelError):
        unpack(_tar(member), into)
    assert not (tmp_path / "outside.txt").exists()
    assert not any(p.is_symlink() for p in into.rglob("*"))


def test_pack_and_unpack_round_trip_a_folder(tmp_path):
    outcome = _made(tmp_path / "made", "D")
    parcel = pack(tmp_path / "made", extra=lambda dropped: {"status.json": b"{}"})
    unpacked = tmp_path / "back"
    unpacked.mkdir()
    names = unpack(parcel.data, unpacked)
    assert sorted(names) == ["params.json", "scenario.xosc", "status.json",
                             "variants/v01/variant.json"]
    expected = f"<OpenSCENARIO id='{outcome['scenario_id']}'/>"
    assert (unpacked / "scenario.xosc").read_text() == expected

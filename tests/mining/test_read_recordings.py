"""read_recordings: one call for a file or a folder; what it cannot read is a warning."""

from __future__ import annotations

import shutil

import pytest

from scenweave.mining.readers import read_recordings


def _by_reader(recordings):
    return {r.reader: r for r in recordings}


def test_folder_walk_reads_each_format_and_warns_about_an_unknown_file(data, tmp_path):
    shutil.copytree(data, tmp_path / "data")
    (tmp_path / "data" / "notes.txt").write_text("not trajectories\n")
    (tmp_path / "data" / ".hidden").write_text("skipped silently\n")
    recordings = list(read_recordings(tmp_path / "data"))
    readers = _by_reader(recordings)
    assert set(readers) == {"commonroad", "highd", "ngsim-csv", ""}
    assert [len(readers[n].tracks) for n in ("commonroad", "highd", "ngsim-csv")] == [3, 4, 5]
    (unknown,) = [r for r in recordings if not r.reader]
    assert unknown.tracks == [] and unknown.source.endswith("notes.txt")
    assert "not a trajectory file" in unknown.warnings[0]
    # the highD meta files are read with their tracks file, not reported as unknown
    assert len(recordings) == 4


def test_a_folder_with_nothing_recognisable_says_so(tmp_path):
    (tmp_path / "readme.md").write_text("# nothing here\n")
    recordings = list(read_recordings(tmp_path))
    assert [r.reader for r in recordings] == ["", ""]
    assert "no trajectory file recognised" in recordings[-1].warnings[0]


def test_a_broken_file_is_a_warning(tmp_path):
    (tmp_path / "scenario.xml").write_text('<?xml version="1.0"?>\n<commonRoad timeStep')
    (recording,) = read_recordings(tmp_path / "scenario.xml")
    assert recording.tracks == [] and "commonroad reader could not read it" in \
        recording.warnings[0]


def test_a_single_file(data):
    (recording,) = read_recordings(data / "ngsim_small.csv")
    assert recording.reader == "ngsim-csv" and recording.source.endswith("ngsim_small.csv")


def test_a_missing_path_raises(tmp_path):
    with pytest.raises(FileNotFoundError):
        list(read_recordings(tmp_path / "nowhere"))

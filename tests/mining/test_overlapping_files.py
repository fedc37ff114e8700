"""One event once (issue 32, item 3): recordings cut from one road with overlapping windows,
each with its own clock and frame, give every event one record, whichever pair of files
overlaps and in whatever order they come, and the record names every file it was seen in."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from scenweave.mining import Recording, Track
from scenweave.mining.mine import mine_recordings
from scenweave.mining.readers import read_recordings
from scenweave.mining.thresholds import load_thresholds
from tests.mining.synthetic import braking, car, recording

LIMITS = load_thresholds()
#: the fields of a track that run per step
PER_STEP = ("t", "x", "y", "heading", "speed", "s", "lane", "lane_index", "road", "lateral")


def window(whole: Recording, start_s: float, end_s: float, source: str,
           turn_rad: float) -> Recording:
    """The steps of ``whole`` from ``start_s`` to ``end_s``, its clock restarted at 0 and its
    frame turned and moved (as CommonRoad puts each file's origin at its own start)."""
    cos, sin = np.cos(turn_rad), np.sin(turn_rad)
    tracks = []
    for track in whole.tracks:
        inside = (track.t >= start_s - 1e-6) & (track.t <= end_s + 1e-6)
        if inside.sum() < 2:
            continue
        part = {k: np.asarray(getattr(track, k))[inside] for k in PER_STEP
                if len(getattr(track, k)) == len(track.t)}
        x, y = part["x"] - 25.0, part["y"] + 9.0
        part |= {"t": np.round(part["t"] - start_s, 3), "x": cos * x - sin * y,
                 "y": sin * x + cos * y}
        tracks.append(Track(**{**track.__dict__, **part}))
    return Recording(source=source, dt=whole.dt, tracks=tracks, reader=whole.reader,
                     lights=whole.lights, junction_lanes=whole.junction_lanes)


def _wobble(t: np.ndarray) -> np.ndarray:
    """A speed that never repeats itself: any two files' clocks are told apart by it."""
    return 20.0 + 2.0 * np.sin(t * 0.7) + 0.05 * t


def road() -> Recording:
    """30 s of a road with three braking leads, at 9, 13.5 and 20 s, each with its follower,
    and one car in a lane of its own whose speed never repeats."""
    tracks = [car("wobble", 30, 0, _wobble, 4)]
    for n, (at, lane) in enumerate(((9.0, 1), (13.5, 2), (20.0, 3))):
        tracks += [car(f"lead{n}", 30, 60 + 5 * n, braking(22, at, 5.0, 12), lane),
                   car(f"ego{n}", 30, 30 + 5 * n, braking(22, at + 0.5, 5.0, 12), lane)]
    return recording(*tracks)


def brakes(out: Path) -> list[dict]:
    path = out / "highway" / "BRAKE.json"
    return json.loads(path.read_text()) if path.exists() else []


def test_three_overlapping_files_write_each_brake_once_naming_every_file(tmp_path):
    whole = road()
    everything = mine_recordings([whole], tmp_path / "whole", LIMITS)
    assert everything.written["BRAKE"] == 3
    files = [window(whole, 0, 16, "A.xml", 0.0), window(whole, 6, 26, "B.xml", 0.4),
             window(whole, 12, 30, "C.xml", -0.3)]
    mine_recordings(files, tmp_path / "cut", LIMITS)
    found = brakes(tmp_path / "cut")
    assert sorted(r["provenance"]["tracks"]["ego"] for r in found) == ["ego0", "ego1", "ego2"]
    seen_in = {r["provenance"]["tracks"]["ego"]: {Path(r["provenance"]["file"]).name}
               | {a["file"] for a in r["provenance"].get("also_in", [])} for r in found}
    assert seen_in == {"ego0": {"A.xml", "B.xml"}, "ego1": {"A.xml", "B.xml", "C.xml"},
                       "ego2": {"B.xml", "C.xml"}}


def test_a_file_joining_two_that_share_nothing_makes_their_events_one(tmp_path):
    whole = road()
    first, last = window(whole, 0, 12, "A.xml", 0.0), window(whole, 16.5, 30, "C.xml", 0.2)
    middle = window(whole, 7, 23, "B.xml", -0.5)
    report = mine_recordings([first, last, middle], tmp_path, LIMITS)  # B comes last
    found = brakes(tmp_path)
    assert sorted(r["provenance"]["tracks"]["ego"] for r in found) == ["ego0", "ego1", "ego2"]
    assert {(d["file"], d["same_as_in"]) for d in report.duplicates if d["class"] == "BRAKE"} \
        == {("B.xml", "A.xml"), ("B.xml", "C.xml")}


def test_a_shared_snippet_cut_in_three_is_mined_once(ngsim_snippets, tmp_path):
    source = ngsim_snippets / "us101" / "USA_US101-25_1_T-1.xml"
    if not source.exists():
        pytest.skip("US-101 25_1 is not among the shared snippets")
    whole = next(iter(read_recordings(source)))
    alone = mine_recordings([whole], tmp_path / "whole", LIMITS)
    cut = [window(whole, 0.0, 4.5, "A.xml", 0.0), window(whole, 1.5, 6.7, "B.xml", 0.3),
           window(whole, 3.0, 6.7, "C.xml", -0.2)]
    report = mine_recordings(cut, tmp_path / "cut", LIMITS)
    assert report.duplicates  # the files share events ...
    written = [json.loads(p.read_text()) for p in (tmp_path / "cut").glob("*/*.json")]
    keys = [(r["maneuver_class"], r["provenance"]["tracks"].get("ego"),
             r["provenance"]["tracks"].get("npc")) for rs in written for r in rs]
    overlapping = [k for k in set(keys) if keys.count(k) > 1]
    assert sum(alone.written.values()) > 0 and not overlapping  # ... and write none twice

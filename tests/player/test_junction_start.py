"""An urban car that starts on a junction's connecting road stays on the ego's path.

Connecting roads overlap where a junction begins; a WorldPosition there is snapped by the
player to whichever road is closest, possibly one that turns off. Sample seed 8 holds such a
record (U4_3, its lead 31 m ahead, inside junction 148 of Town04): placed by world position,
its lead turned off, drove round the block and crossed the ego at 17.95 s.
"""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.ingest.samples import write_urban_samples

SCENARIO = "U4_3_20230927T203000_1181p0"


def test_a_lead_starting_in_a_junction_drives_on_the_egos_roads(tmp_path, esmini):
    write_urban_samples(tmp_path / "raw", seed=8, per_class=3)
    ran = CliRunner().invoke(cli, ["run", str(tmp_path / "raw"), "--out", str(tmp_path),
                                   "--run-id", "r", "--no-llm", "--classes", "U4_3"])
    folder = tmp_path / "r" / SCENARIO
    params = json.loads((folder / "params.json").read_text())
    assert params["lead_in_junction"] is True, "the record no longer starts its lead in a junction"
    assert f'roadId="{params["lead_road_id"]}"' in (folder / "scenario.xosc").read_text()
    status = json.loads((folder / "status.json").read_text())
    assert status["status"] == "ok", (status.get("error"), ran.output)
    tracks = json.loads((folder / "replay.json").read_text())["tracks"]
    ego, lead = _roads_in_order(tracks["hero"]), _roads_in_order(tracks["lead"])
    assert lead[0] == params["lead_road_id"] and lead[0] in ego
    behind = ego[ego.index(lead[0]):]
    assert lead[:len(behind)] == behind, "the lead left the roads the ego drives after it"


def _roads_in_order(track: dict) -> list[int]:
    roads: list[int] = []
    for road in track["road"]:
        if not roads or roads[-1] != road:
            roads.append(road)
    return roads

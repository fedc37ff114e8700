"""A small run for the viewer's tests: an agent run with recorded replies (a cut-in that
needs a repair, a stop at a red light that is right first time), played in the real esmini,
plus a hand-edited copy of the cut-in that fails its replay, played with
``scenweave replay --force``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from click.testing import CliRunner

from scenweave.agent import AgentSettings
from scenweave.cli import cli
from scenweave.inputs import InputSelection
from scenweave.pipeline import PipelineSettings
from scenweave.player import ReplaySettings
from scenweave.runner import run_batch
from scenweave.sandbox import SandboxSettings
from tests.replies import right_replies

CUT_IN = "CINF_B0_CINF_BINS_VALUES_row000000"
RUN_ID = "viewer"
#: not a script at all: the first attempt fails (taxonomy syntax) and is repaired
NO_CODE = "I cannot help with that."
#: the hand-edited copy's NPC ends its speed change this much slower than the record (m/s)
EDITED_SLOWER_MS = 8.0
EDITED = "CINF_hand_edited"


def make_run(raw: Path, root: Path) -> Path:
    """The run folder ``root/runs/viewer`` (agent, replay on) for ``raw`` sample data."""
    selection = InputSelection(classes=("CINF", "U4_1"), per_class=1)
    right = right_replies(raw, selection)
    replies = root / "replies.json"
    replies.write_text(json.dumps({sid: [NO_CODE, reply] if sid == CUT_IN else [reply]
                                   for sid, reply in right.items()}))
    agent = AgentSettings(llm="replay", replay_file=replies, repair="error-feedback",
                          sandbox=SandboxSettings(backend="bwrap", wall_time_s=30),
                          replay=ReplaySettings())
    result = run_batch(raw, root / "runs", selection,
                       PipelineSettings(no_llm=False, agent=agent, replay=ReplaySettings()),
                       run_id=RUN_ID)
    return result.folder.root


def edit_cut_in(run: Path, out: Path) -> Path:
    """A copy of the cut-in whose NPC slows down by ``EDITED_SLOWER_MS`` more than recorded,
    played with ``scenweave replay --force`` (it fails the parameter checks); its folder."""
    folder = out / EDITED
    folder.mkdir(parents=True)
    for name in ("scenario.xosc", "params.json"):
        shutil.copy(run / CUT_IN / name, folder / name)
    params = json.loads((folder / "params.json").read_text())
    xosc = (folder / "scenario.xosc").read_text()
    target = f'<AbsoluteTargetSpeed value="{params["npc_end_speed_ms"]}" />'
    assert xosc.count(target) >= 1, "the cut-in's NPC speed target is not in the file"
    slower = f'<AbsoluteTargetSpeed value="{params["npc_end_speed_ms"] - EDITED_SLOWER_MS}" />'
    # the NPC's speed change is the last speed action of the story
    head, _, tail = xosc.rpartition(target)
    (folder / "scenario.xosc").write_text(head + slower + tail)
    result = CliRunner().invoke(cli, ["replay", str(folder / "scenario.xosc"), "--force"])
    assert "REPLAY_SPEED" in result.output, result.output
    return folder

"""What a replay figure knows of a scenario: the record's values (``params.json``), the
verdict on its replay (``status.json``), the scenario's storyboard (for the scripted speed
changes) and a mined record's recorded series, each possibly missing; and the colours that
tell the actors and the verdict apart.
"""


from __future__ import annotations

import math
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np

from scenweave.schemas.params import Params, unchecked
from scenweave.schemas.params import number as number_of
from scenweave.schemas.scenario_folder import (
    PARAMS_NAME,
    RECORDED_NAME,
    STATUS_NAME,
    XOSC_NAME,
    ReplayVerdict,
    VerdictMark,
    read_json_object,
    read_verdict,
)

EGO = "hero"
EGO_COLOUR = "#1f4e9c"
OTHER_COLOURS = ("#e07b00", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")
LIGHT_COLOURS = {"green": "#2ca02c", "yellow": "#f2c200", "red": "#d62728"}
FAIL_COLOUR = "#cf222e"
PASS_COLOUR = "#1a7f37"


class ReplayFacts:
    """The record's values (params), the outcome (status), the judge's verdict on the replay
    (``verdict.json``: what it expected, with its tolerances, and its findings at their
    times) and the scenario (for the map it names), each possibly missing."""

    def __init__(self, folder: Path, params: Params, status: dict, doc: Any,
                 judged: ReplayVerdict | None = None):
        self.folder, self.params, self.status, self.doc = folder, params, status, doc
        self.judged = judged

    @classmethod
    def read(cls, folder: Path) -> ReplayFacts:
        return cls(folder, unchecked(read_json_object(folder / PARAMS_NAME)),
                   read_json_object(folder / STATUS_NAME), _scenario_doc(folder / XOSC_NAME),
                   read_verdict(folder))

    def marks(self, kind: Literal["speed_marks", "gap_marks"],
              what: str | None = None) -> list[VerdictMark]:
        """The values the judge expected (of one kind, ``what`` one sort of them); none
        without a verdict."""
        return [m for m in (self.judged[kind] if self.judged else [])
                if what is None or m["what"] == what]

    def tolerance(self, name: Literal["speed_ms", "gap_m"]) -> float | None:
        """The judge's tolerance (None without a verdict: the mark is drawn without bars)."""
        return self.judged["tolerances"][name] if self.judged else None

    @property
    def scenario_id(self) -> str:
        return str(self.params.get("scenario_id") or self.status.get("scenario_id")
                   or self.folder.name)

    @property
    def maneuver_class(self) -> str:
        return str(self.params.get("maneuver_class") or self.status.get("maneuver_class") or "?")

    @property
    def replay(self) -> dict | None:
        replay = self.status.get("replay")
        return replay if isinstance(replay, dict) else None

    def findings(self) -> list[str]:
        """The replay's findings as ``CODE message`` lines: the verdict's, else (a folder
        judged before verdicts were written) status.json's validation errors, or only the
        codes when the messages were not kept."""
        if self.judged is not None:
            return [f"{f['code']} {f['message']}".strip() for f in self.judged["findings"]]
        validation = self.status.get("validation") or {}
        lines = [f"{e.get('code')} {e.get('message', '')}".strip()
                 for e in validation.get("errors") or []
                 if isinstance(e, dict) and str(e.get("code", "")).startswith("REPLAY")]
        if not lines and self.replay:
            lines = [str(c) for c in self.replay.get("codes") or []]
        return lines

    def verdict(self) -> tuple[str, str]:
        """The title's verdict and its colour."""
        replay = self.replay
        if replay is None:
            return "replay not judged", "black"
        if replay.get("passed"):
            return "replay passed", PASS_COLOUR
        codes = replay.get("codes") or []
        return "replay FAILED" + (f": {', '.join(codes)}" if codes else ""), FAIL_COLOUR

    @cached_property
    def recorded(self) -> dict:
        """What a mined record recorded (``recorded.json``, else params ``recorded_series``;
        empty for other records)."""
        return (read_json_object(self.folder / RECORDED_NAME)
                or self.params.get("recorded_series") or {})

    def recorded_curve(self, key: str) -> tuple[np.ndarray, np.ndarray] | None:
        """(scenario time, values) of a recorded series: the record's event starts when the
        scenario's manoeuvre does."""
        recorded = self.recorded
        values = recorded.get(key)
        if not values or "t" not in recorded:
            return None
        shift = self.number("maneuver_start_s") or 0.0
        times = np.asarray(recorded["t"], dtype=float) + shift
        return times, np.asarray([math.nan if v is None else v for v in values], dtype=float)

    @property
    def map_path(self) -> Path | None:
        """The map the scenario was made for (params ``map``, else its LogicFile)."""
        from scenweave import roads

        try:
            return roads.resolve_map(self.params.get("map") or (
                self.doc.logic_file if self.doc is not None else None)).path
        except roads.UnknownMapError:
            return None

    def number(self, key: str) -> float | None:
        return number_of(self.params, key)


def _scenario_doc(path: Path) -> Any:
    from lxml import etree

    from scenweave.judge.scenario_doc import ScenarioDoc

    try:
        return ScenarioDoc(etree.parse(str(path)))
    except (OSError, etree.XMLSyntaxError):
        return None

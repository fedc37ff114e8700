"""What a manoeuvre class is, in one place: :class:`Maneuver`.

Every stage asks a class's definition instead of keeping its own list of codes: ingest
(layout fields, extraction, playability), the sample data (its generator), the spawn stage
(where its NPCs start, which neighbour lanes it needs), the corpus (its reference script) and
the checks (what the scenario must show, statically and when played). A new class is one
:class:`Maneuver` (see ``docs/adding-a-manoeuvre.md``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from scenweave.errors import InputError

Domain = Literal["highway", "urban"]
#: where a class's principal NPC starts
NpcPosition = Literal["front", "behind"]
#: a highway file's row: layout field -> value
Row = Mapping[str, Any]
#: the layout's conventions for a class (``relative_speed_sign``, ``direction_is``...)
Conventions = Mapping[str, Any]
#: a class's part of the params (the ``Params`` contract lives above, in ``schemas.params``)
ParamsPart = dict[str, Any]
#: a highway file's row, the class code, the layout's conventions -> the class's params
Extractor = Callable[[Row, str, Conventions], ParamsPart]
#: random generator, number of rows, class code -> one column of values per layout field
Sampler = Callable[[np.random.Generator, int, str], dict[str, np.ndarray]]


class RecordFieldError(InputError, ValueError):
    """A record a class cannot read: the message and the field at fault (ingest turns it into
    an input issue naming file and row)."""

    def __init__(self, message: str, field: str) -> None:
        super().__init__(message)
        self.field = field


def no_lane_sides(params: Mapping[str, Any]) -> list[str]:
    """Most classes need no neighbour lane."""
    return []


@dataclass(frozen=True)
class SameLane:
    """An NPC that shares the ego's lane: its params prefix, the file's column of its start
    gap, and for how long (``all_along``: the whole record; ``at_start``: at t = 0 only, as a
    braking lead the ego reacts to or a car that leaves the lane)."""

    prefix: str
    gap_column: str
    span: Literal["all_along", "at_start"]


@dataclass(frozen=True)
class Maneuver:
    """One manoeuvre class. Behaviour flags default to "not this class's business"."""

    #: the class code of the records (``BRAKE``, ``U4_1``)
    code: str
    #: the corpus tag (thesis Table 5.4), also the params' ``maneuver_tag``
    tag: str
    domain: Domain
    #: a readable name for reports and descriptions
    name: str
    #: the reference script: a file name in ``corpus/`` or an absolute path
    script: str

    # -- highway records: the file layout and extraction --------------------------------------
    #: the layout fields extraction reads; a custom layout must keep these names
    layout_fields: tuple[str, ...] = ()
    #: the params its reference script's worked example shows the LLM (``corpus.
    #: worked_example``); built-in classes keep theirs in ``corpus/worked_examples.json``
    example: Mapping[str, Any] | None = None
    #: the layout-file entry (``tag``, ``npc_position``, ``columns``...) used when the layout
    #: file has none for this class (built-in classes live in schemas/highway_layouts.json)
    layout: Mapping[str, Any] | None = None
    #: the class's part of the params, from one row of its file
    extract: Extractor | None = None
    #: the sample-data generator of its rows
    sample: Sampler | None = None
    #: rows only a speed profile of two or more phases shows (``sample-data --phased``)
    sample_phased: Sampler | None = None
    #: the layout holds ``relative_speed_sign`` (npc = ego + sign * relative speed)
    relative_speed: bool = False
    #: the ego's end speed follows from its start speed (None: the record gives it)
    ego_end_speed_factor: float | None = None

    # -- the spawn stage ----------------------------------------------------------------------
    #: where the principal NPC starts: "front", "behind" or None (no single NPC)
    npc_position: NpcPosition | None = None
    #: the neighbour lanes the scenario needs ("left", "right") for given params
    lane_sides: Callable[[Mapping[str, Any]], list[str]] = no_lane_sides
    #: the NPC starts in the neighbour lane and cuts in
    npc_starts_beside: bool = False
    #: NPCs are placed by surrounding slot (center/right/left), not as one ``npc``
    surrounding_slots: bool = False
    #: the NPC sharing the ego's lane, which the record must keep clear of the ego
    same_lane: SameLane | None = None

    # -- what the scenario must show -----------------------------------------------------------
    #: an NPC whose speed change is the manoeuvre; the scenario needs it
    npc_speed_change: bool = False
    #: that change is braking: an NPC SpeedAction must slow it down
    lead_brakes: bool = False
    #: who changes lane: "npc", "hero" or None (then no lane change may happen)
    lane_change: Literal["npc", "hero"] | None = None
    #: for an NPC lane change: it ends in the ego's lane (a cut-in) or leaves it
    npc_ends_in_ego_lane: bool | None = None
    #: the ego reacts to a slower NPC ending up in front: watched from t = 0 ("from_start")
    #: or from the cut-in on ("from_cut_in")
    ego_reacts: Literal["from_start", "from_cut_in"] | None = None
    #: the record's end gap is part of the manoeuvre (checked when played, and playable only
    #: if the speeds lead to it)
    gap_at_end: bool = False

    # -- urban --------------------------------------------------------------------------------
    #: the light the ego meets: None (no light), "red", "green", "green_or_orange"
    light: Literal["red", "green", "green_or_orange"] | None = None
    #: the ego stops at the light's stop line
    stops_at_line: bool = False
    #: the ego's movement through the junction
    turn: Literal["straight", "right"] = "straight"
    #: how the description says what the ego does at the light ("stops before")
    verb: str = "keeps its lane"
    #: a lead car may drive ahead of the ego in the sample data
    lead_allowed: bool = False

    def __post_init__(self) -> None:
        if self.domain == "highway" and self.extract is None:
            raise ValueError(f"highway class {self.code}: an extract function is required")

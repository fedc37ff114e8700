"""What a variant of a scenario changed, and whether it kept what the record fixes.

A variant (``scenweave run --vary N``) may change only what the record does not say: the
weather and time of day (the ``EnvironmentAction``), the vehicle models of the record's
actors (their ``Vehicle``), background traffic (entities the faithful scenario does not
have), and the lane (a recorded actor's start lane); all but the weather only as asked, to
the values ScenWeave worked out (``ingest.variants.vary``), which the ``reference``
script played with them shows. Everything the record fixes must stay: the map, every recorded
actor's start (``Init``), the stories of the recorded actors and the stop trigger, as the
faithful scenario has them, or, for a variant made as asked, as the reference has them
(another model keeps the gaps between bumpers, so the cars start elsewhere; the record one
lane over starts from another spawn point). Whether the variant still plays the recorded
manoeuvre is the replay's to judge (``judge.replay``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from scenweave.judge.findings import Finding
from scenweave.schemas.params import Params

#: what a variant may change, by what the reader sees
ASPECTS = ("weather", "vehicles", "traffic", "lane")
#: the aspects a variant changes only as asked (to the ``reference``), and why
UNASKED_WHY = {
    "vehicles": "the record's gaps are between bumpers, so another model moves the cars",
    "traffic": "an added vehicle must keep clear of the record, where the spawn stage puts it",
    "lane": "the record fits one lane over only where the spawn stage places it",
}


def aspect_of(number: int) -> tuple[str, int]:
    """The aspect variant ``number`` (from 1) changes, ``ASPECTS`` in turn, and how many of
    that aspect were asked before it (its round)."""
    return ASPECTS[(number - 1) % len(ASPECTS)], (number - 1) // len(ASPECTS)


@dataclass(frozen=True)
class Asked:
    """What a variant is asked to play, worked out before the agent writes it
    (``ingest.variants.vary``): the record's params as the variant must play them, or, where
    the record leaves no room for a variant of this aspect, ``error`` (``CODE: why``), and no
    LLM call is spent on it."""

    aspect: str
    params: Params | None
    error: str | None = None


@dataclass
class Variation:
    """The aspects a variant changed and what it changed that the record fixes."""

    changed: list[str] = field(default_factory=list)
    violations: list[Finding] = field(default_factory=list)
    #: it matches the ``reference`` (what it was asked to change), not the faithful scenario
    as_asked: bool = False


def compare(faithful: Path, variant: Path, reference: Path | None = None) -> Variation:
    """How ``variant`` differs from the ``faithful`` scenario file; ``reference``: the
    reference script played with the values the variant was asked to change."""
    old, new = etree.parse(str(faithful)).getroot(), etree.parse(str(variant)).getroot()
    found = Variation()
    if _canonical(old.find(".//EnvironmentAction")) != _canonical(new.find(".//EnvironmentAction")):
        found.changed.append("weather")
    recorded = _names(old)
    present = set(_names(new))
    missing = [name for name in recorded if name not in present]
    if missing:
        found.violations.append(Finding("VARY_ACTOR_MISSING", f"the variant drops the "
                                        f"recorded actor(s) {', '.join(missing)}"))
    if present - set(recorded):
        found.changed.append("traffic")
    kept = [name for name in recorded if name in present]
    if any(_canonical(_vehicle(old, n)) != _canonical(_vehicle(new, n)) for n in kept):
        found.changed.append("vehicles")
    if any(_start_lanes(old, n) != _start_lanes(new, n) for n in kept):
        found.changed.append("lane")
    fixed = _fixed_parts(kept)
    asked = None if reference is None else etree.parse(str(reference)).getroot()
    if asked is not None and _marks(new, kept) == _marks(asked, kept) != _marks(old, kept):
        found.as_asked = True  # it made the asked change: the rest must follow as it does there
        added = sorted((present | set(_names(asked))) - set(recorded))
        found.violations += [Finding("VARY_RECORDED", f"{what} is not as the reference script "
                                     "plays the asked values")
                             for what, path in [*fixed, *_added_parts(added)]
                             if _differs(asked, new, path)]
        return found
    found.violations += [Finding("VARY_RECORDED", f"the variant changes {what}, which the "
                                 "record fixes") for what, path in fixed
                         if _differs(old, new, path)]
    found.violations += [Finding("VARY_UNASKED", f"the variant changes the {aspect} by itself: "
                                 f"{UNASKED_WHY[aspect]}")
                         for aspect in found.changed if aspect in UNASKED_WHY]
    return found


#: each recorded actor's (model, start lanes), and the names of the vehicles added
Marks = tuple[list[tuple[str, list[str]]], list[str]]


def _marks(root: etree._Element, actors: list[str]) -> Marks:
    """What a variant is asked to change itself: each recorded actor's model and start lane,
    and which vehicles it adds."""
    return ([(_canonical(_vehicle(root, name)), _start_lanes(root, name)) for name in actors],
            sorted(set(_names(root)) - set(actors)))


def _names(root: etree._Element) -> list[str]:
    return [o.get("name", "") for o in root.findall(".//Entities/ScenarioObject")]


def _added_parts(names: list[str]) -> list[tuple[str, str]]:
    """A vehicle the variant adds: as the reference has it, from model to story."""
    parts = []
    for name in names:
        parts.append((f"the added {name}", f".//Entities/ScenarioObject[@name='{name}']"))
        parts.append((f"the added {name}'s start", _start_path(name)))
        parts.append((f"the added {name}'s story", _story_path(name)))
    return parts


def _differs(one: etree._Element, other: etree._Element, path: str) -> bool:
    return _canonical_all(one, path) != _canonical_all(other, path)


def _start_lanes(root: etree._Element, actor: str) -> list[str]:
    """The lane ``actor`` starts in: its ``LanePosition``'s lane id, or where the scenario
    places it by world coordinates (urban), the whole position."""
    lanes = _xpath_strings(root, f"{_start_path(actor)}//LanePosition/@laneId")
    return lanes or [_canonical(p) for p in
                     _xpath_elements(root, f"{_start_path(actor)}//WorldPosition")]


def _start_path(actor: str) -> str:
    return f".//Init//Private[@entityRef='{actor}']"


def _story_path(actor: str) -> str:
    return f".//ManeuverGroup[Actors/EntityRef/@entityRef='{actor}']"


def _fixed_parts(actors: list[str]) -> list[tuple[str, str]]:
    parts = [("the map", "./RoadNetwork"), ("the stop trigger", ".//Storyboard/StopTrigger")]
    for name in actors:
        parts.append((f"{name}'s start", _start_path(name)))
        parts.append((f"{name}'s story", _story_path(name)))
    return parts


def _vehicle(root: etree._Element, name: str) -> etree._Element | None:
    return root.find(f".//Entities/ScenarioObject[@name='{name}']/Vehicle")


def _canonical_all(root: etree._Element, path: str) -> list[str]:
    return [_canonical(element) for element in _xpath_elements(root, path)]


def _xpath_elements(root: etree._Element, path: str) -> list[etree._Element]:
    """The elements an XPath that selects elements finds."""
    found = root.xpath(path)
    return [item for item in found if isinstance(item, etree._Element)] \
        if isinstance(found, list) else []


def _xpath_strings(root: etree._Element, path: str) -> list[str]:
    """The values an XPath that selects attributes (or text) finds."""
    found = root.xpath(path)
    return [str(item) for item in found if isinstance(item, str)] \
        if isinstance(found, list) else []


def _canonical(element: etree._Element | None) -> str:
    return "" if element is None else etree.tostring(element, method="c14n").decode()

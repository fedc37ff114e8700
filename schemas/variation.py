"""What a variant of a scenario changed, and whether it kept what the record fixes.

A variant (``scenweave run --vary N``) may change only what the record does not say: the
weather and time of day (the ``EnvironmentAction``), the vehicle models of the record's
actors (their ``Vehicle``), background traffic (entities the faithful scenario does not
have), and the lane: the whole scenario one lane over, every recorded actor's start moved by
the same number of lanes (highway; whether the map has that lane and the gaps still hold
there is the replay's to judge). Everything the record
fixes must stay as the faithful scenario has it: the map, every recorded actor's start
(``Init``), the stories of the recorded actors and the stop trigger. Whether the variant still
plays the recorded manoeuvre is the replay's to judge (``schemas.replay``).
"""

from __future__ import annotations

from copy import deepcopy
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from scenweave.schemas.findings import Finding

#: what a variant may change, by what the reader sees
ASPECTS = ("weather", "vehicles", "traffic", "lane")


@dataclass
class Variation:
    """The aspects a variant changed and what it changed that the record fixes."""

    changed: list[str] = field(default_factory=list)
    violations: list[Finding] = field(default_factory=list)
    #: how many lanes every recorded actor moved (the same for all; 0: none)
    lane_shift: int = 0

    @property
    def is_variant(self) -> bool:
        """It changed something allowed and nothing fixed."""
        return bool(self.changed) and not self.violations


def compare(faithful: Path, variant: Path) -> Variation:
    """How ``variant`` differs from the ``faithful`` scenario file."""
    old, new = etree.parse(str(faithful)).getroot(), etree.parse(str(variant)).getroot()
    found = Variation()
    if _canonical(old.find(".//EnvironmentAction")) != _canonical(new.find(".//EnvironmentAction")):
        found.changed.append("weather")
    recorded = [o.get("name") for o in old.findall(".//Entities/ScenarioObject")]
    present = {o.get("name") for o in new.findall(".//Entities/ScenarioObject")}
    missing = [name for name in recorded if name not in present]
    if missing:
        found.violations.append(Finding("VARY_ACTOR_MISSING", f"the variant drops the "
                                        f"recorded actor(s) {', '.join(missing)}"))
    if present - set(recorded):
        found.changed.append("traffic")
    kept = [name for name in recorded if name in present]
    if any(_canonical(_vehicle(old, n)) != _canonical(_vehicle(new, n)) for n in kept):
        found.changed.append("vehicles")
    found.lane_shift = _lane_shift(old, new, kept)
    if found.lane_shift:
        found.changed.append("lane")
        new = _shifted(new, -found.lane_shift)
    found.violations += [Finding("VARY_RECORDED", f"the variant changes {what}, which the "
                                 "record fixes")
                         for what, path in _fixed_parts(kept)
                         if _canonical_all(old, path) != _canonical_all(new, path)]
    return found


def _lane_shift(old: etree._Element, new: etree._Element, actors: list[str]) -> int:
    """The lanes every recorded actor's start moved by, when all moved by the same number
    (the whole scenario one lane over); 0 otherwise (a lone move is a change of the record)."""
    shifts = set()
    for name in actors:
        before, after = _start_lane(old, name), _start_lane(new, name)
        if before is None or after is None:
            return 0
        shifts.add(after - before)
    return shifts.pop() if len(shifts) == 1 else 0


def _start_lane(root: etree._Element, name: str) -> int | None:
    found = root.xpath(f".//Init//Private[@entityRef='{name}']//LanePosition/@laneId")
    try:
        return int(found[0]) if len(found) == 1 else None
    except ValueError:
        return None


def _shifted(root: etree._Element, by: int) -> etree._Element:
    """A copy of ``root`` with every start lane moved by ``by``."""
    copy = deepcopy(root)
    for position in copy.xpath(".//Init//LanePosition"):
        position.set("laneId", str(int(position.get("laneId")) + by))
    return copy


def _fixed_parts(actors: list[str]) -> list[tuple[str, str]]:
    parts = [("the map", "./RoadNetwork"), ("the stop trigger", ".//Storyboard/StopTrigger")]
    for name in actors:
        parts.append((f"{name}'s start", f".//Init//Private[@entityRef='{name}']"))
        parts.append((f"{name}'s story", f".//ManeuverGroup[Actors/EntityRef/@entityRef='{name}']"))
    return parts


def _vehicle(root: etree._Element, name: str) -> etree._Element | None:
    return root.find(f".//Entities/ScenarioObject[@name='{name}']/Vehicle")


def _canonical_all(root: etree._Element, path: str) -> list[str]:
    return [_canonical(element) for element in root.xpath(path)]


def _canonical(element: etree._Element | None) -> str:
    return "" if element is None else etree.tostring(element, method="c14n").decode()

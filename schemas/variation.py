"""What a variant of a scenario changed, and whether it kept what the record fixes.

A variant (``scenweave run --vary N``) may change only what the record does not say: the
weather and time of day (the ``EnvironmentAction``), the vehicle models of the record's
actors (their ``Vehicle``), background traffic (entities the faithful scenario does not
have), and the lane: the whole scenario one lane over, where the spawn stage found the record
room (``SpawnMatcher.lane_over``); the reference script played there is the ``moved``
scenario, and a lane variant must start every recorded actor as it does. Everything else the
record fixes must stay as the faithful scenario has it: the map, every recorded actor's start
(``Init``), the stories of the recorded actors and the stop trigger. Whether the variant still
plays the recorded manoeuvre is the replay's to judge (``schemas.replay``).
"""

from __future__ import annotations

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

    @property
    def is_variant(self) -> bool:
        """It changed something allowed and nothing fixed."""
        return bool(self.changed) and not self.violations

    @property
    def moved(self) -> bool:
        """It is the scenario one lane over (judged against the ``moved`` scenario)."""
        return "lane" in self.changed


def compare(faithful: Path, variant: Path, moved: Path | None = None) -> Variation:
    """How ``variant`` differs from the ``faithful`` scenario file; ``moved``: the faithful
    scenario one lane over (the reference played where ``SpawnMatcher.lane_over`` put it)."""
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
    fixed = _fixed_parts(kept)
    base = old
    if moved is not None:
        lane_over = etree.parse(str(moved)).getroot()
        if _starts(new, kept) == _starts(lane_over, kept) != _starts(old, kept):
            found.changed.append("lane")
            base = lane_over
    found.violations += [Finding("VARY_RECORDED", f"the variant changes {what}, which the "
                                 "record fixes")
                         for what, path in fixed
                         if _canonical_all(base, path) != _canonical_all(new, path)]
    return found


def _starts(root: etree._Element, actors: list[str]) -> list[list[str]]:
    return [_canonical_all(root, _start_path(name)) for name in actors]


def _start_path(actor: str) -> str:
    return f".//Init//Private[@entityRef='{actor}']"


def _fixed_parts(actors: list[str]) -> list[tuple[str, str]]:
    parts = [("the map", "./RoadNetwork"), ("the stop trigger", ".//Storyboard/StopTrigger")]
    for name in actors:
        parts.append((f"{name}'s start", _start_path(name)))
        parts.append((f"{name}'s story", f".//ManeuverGroup[Actors/EntityRef/@entityRef='{name}']"))
    return parts


def _vehicle(root: etree._Element, name: str) -> etree._Element | None:
    return root.find(f".//Entities/ScenarioObject[@name='{name}']/Vehicle")


def _canonical_all(root: etree._Element, path: str) -> list[str]:
    return [_canonical(element) for element in root.xpath(path)]


def _canonical(element: etree._Element | None) -> str:
    return "" if element is None else etree.tostring(element, method="c14n").decode()

"""The five deterministic auto-fix rules of thesis Table 5.7, applied before XSD validation.

Each rule takes the file's text and returns it fixed (or unchanged); the names of the rules
that changed something are reported as ``fixes_applied``.
"""

from __future__ import annotations

import re
from collections.abc import Callable

DEFAULT_TIME_OF_DAY = '<TimeOfDay animation="false" dateTime="2020-01-01T12:00:00"/>'
DEFAULT_PRECIPITATION = '<Precipitation precipitationType="dry" intensity="0.0"/>'


def _precipitation_attribute(text: str) -> str:
    return re.sub(r"\bprecipitationIntensity=", "intensity=", text)


def _missing_time_of_day(text: str) -> str:
    def fix(match: re.Match[str]) -> str:
        body: str = match.group(0)
        if "<TimeOfDay" in body:
            return body
        return re.sub(r"(<Environment\b[^>]*>)", r"\1" + DEFAULT_TIME_OF_DAY, body, count=1)

    return re.sub(r"<Environment\b[^>]*>.*?</Environment>", fix, text, flags=re.S)


def _missing_precipitation(text: str) -> str:
    def fix(match: re.Match[str]) -> str:
        body: str = match.group(0)
        if "<Precipitation" in body:
            return body
        if "<Fog" in body:  # the schema orders Weather's children: Sun, Fog, Precipitation
            return re.sub(r"(<Fog\b[^>]*/>|<Fog\b.*?</Fog>)", r"\1" + DEFAULT_PRECIPITATION,
                          body, count=1, flags=re.S)
        return body.replace("</Weather>", DEFAULT_PRECIPITATION + "</Weather>", 1)

    return re.sub(r"<Weather\b[^>]*>.*?</Weather>", fix, text, flags=re.S)


def _orphan_signal_state_close(text: str) -> str:
    # <TrafficSignalStateAction .../> is self-closing in valid files; a closing tag with no
    # opening element is the LLM artefact the thesis describes
    opens = len(re.findall(r"<TrafficSignalStateAction\b[^>]*[^/]>", text))
    closes = len(re.findall(r"</TrafficSignalStateAction>", text))
    for _ in range(max(closes - opens, 0)):
        text = re.sub(r"(?s)(.*)</TrafficSignalStateAction>", r"\1", text, count=1)
    return text


def _delay_expression(text: str) -> str:
    def fix(match: re.Match[str]) -> str:
        value = match.group(2)
        try:
            float(value)
            whole: str = match.group(0)
            return whole
        except ValueError:
            return f'{match.group(1)}"0"'

    return re.sub(r'(\bdelay=)"([^"]*)"', fix, text)


#: (name, rule) in the order they run
RULES: list[tuple[str, Callable[[str], str]]] = [
    ("precipitationIntensity->intensity", _precipitation_attribute),
    ("missing TimeOfDay", _missing_time_of_day),
    ("missing Precipitation", _missing_precipitation),
    ("spurious </TrafficSignalStateAction>", _orphan_signal_state_close),
    ("delay expression->0", _delay_expression),
]


def apply_fixes(text: str) -> tuple[str, list[str]]:
    """The text with every rule applied, and the names of the rules that changed it."""
    applied = []
    for name, rule in RULES:
        fixed = rule(text)
        if fixed != text:
            applied.append(name)
            text = fixed
    return text, applied

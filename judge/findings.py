"""What the validator reports: findings with a code, a severity, a message and a line."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, Literal, NotRequired, TypedDict

if TYPE_CHECKING:  # the player loads esmini's bindings: only the type is needed here
    from scenweave.player.playback import Playback

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Finding:
    """One problem in a scenario file."""

    code: str
    message: str
    severity: Severity = "error"
    line: int | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class ReplaySummary(TypedDict):
    """What the replay of a validated scenario showed (``ValidationResult.replay``)."""

    played: bool
    passed: bool
    #: the REPLAY_* codes found, sorted
    codes: list[str]
    timings_s: dict[str, float]
    #: per "<entity> <quantity>", how far the replay is from a record's series
    series_errors: NotRequired[dict[str, dict[str, float]]]


@dataclass
class ValidationResult:
    """``{valid, fixes_applied, errors[{code, severity, message, line}], domain}`` (SPEC §8)."""

    valid: bool
    fixes_applied: list[str] = field(default_factory=list)
    errors: list[Finding] = field(default_factory=list)
    domain: str | None = None
    #: the replay's summary when the scenario was played, else None
    replay: ReplaySummary | None = None
    #: the ``player.Playback`` itself (not serialised: the caller writes it as replay.json)
    playback: Playback | None = field(default=None, repr=False, compare=False)

    @property
    def error_codes(self) -> list[str]:
        """Codes of the error-severity findings, in order."""
        return [f.code for f in self.errors if f.severity == "error"]

    def to_dict(self) -> dict[str, Any]:
        return {"valid": self.valid, "fixes_applied": list(self.fixes_applied),
                "errors": [f.to_dict() for f in self.errors], "domain": self.domain,
                "replay": self.replay}


def failure_category(findings: Sequence[Mapping[str, Any]]) -> str:
    """The error-taxonomy word of a failed validation (thesis §6.1, extended): ``replay`` when
    only the replay failed (the file was right, playing it did not show the record),
    ``fidelity`` when only parameter-fidelity checks failed, else ``validation``. Warnings do
    not count."""
    codes = [f["code"] for f in findings if f.get("severity", "error") == "error"]
    if codes and all(code.startswith("REPLAY") for code in codes):
        return "replay"
    if codes and all(code.startswith("FIDELITY") for code in codes):
        return "fidelity"
    return "validation"

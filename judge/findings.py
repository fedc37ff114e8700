"""What the validator reports: findings with a code, a severity, a message and a line."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Literal

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Finding:
    """One problem in a scenario file."""

    code: str
    message: str
    severity: Severity = "error"
    line: int | None = None

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class ValidationResult:
    """``{valid, fixes_applied, errors[{code, severity, message, line}], domain}`` (SPEC §8)."""

    valid: bool
    fixes_applied: list[str] = field(default_factory=list)
    errors: list[Finding] = field(default_factory=list)
    domain: str | None = None
    #: the replay's summary when the scenario was played (``played``, ``passed``, ``codes``,
    #: ``timings_s``), else None
    replay: dict | None = None
    #: the ``player.Playback`` itself (not serialised: the caller writes it as replay.json)
    playback: object | None = field(default=None, repr=False, compare=False)

    @property
    def error_codes(self) -> list[str]:
        """Codes of the error-severity findings, in order."""
        return [f.code for f in self.errors if f.severity == "error"]

    def to_dict(self) -> dict:
        return {"valid": self.valid, "fixes_applied": list(self.fixes_applied),
                "errors": [f.to_dict() for f in self.errors], "domain": self.domain,
                "replay": self.replay}


def failure_category(findings: list[dict]) -> str:
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

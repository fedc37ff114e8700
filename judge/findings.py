"""What the validator reports: findings with a code, a severity, a message and a line."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from scenweave.files import write_json_atomic
from scenweave.schemas.scenario_folder import (
    REPLAY_NAME,
    VERDICT_NAME,
    ReplaySummary,
    ReplayVerdict,
)

if TYPE_CHECKING:  # the player loads esmini's bindings: only the type is needed here
    from scenweave.player.playback import Playback

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Finding:
    """One problem in a scenario file, or in its replay: then with the time it happened
    (``time_s``, written into the verdict, not into ``to_dict``'s validation record)."""

    code: str
    message: str
    severity: Severity = "error"
    line: int | None = None
    time_s: float | None = None

    def to_dict(self) -> dict[str, Any]:
        found = asdict(self)
        del found["time_s"]
        return found


@dataclass
class ValidationResult:
    """``{valid, fixes_applied, errors[{code, severity, message, line}], domain}`` (SPEC §8)."""

    valid: bool
    fixes_applied: list[str] = field(default_factory=list)
    errors: list[Finding] = field(default_factory=list)
    domain: str | None = None
    #: the replay's summary when the scenario was played, else None
    replay: ReplaySummary | None = None
    #: the judge's verdict on the replay (``verdict.json``), when it was played
    verdict: ReplayVerdict | None = None
    #: the ``player.Playback`` itself (not serialised: the caller writes it as replay.json)
    playback: Playback | None = field(default=None, repr=False, compare=False)

    def write_replay(self, folder: Path) -> None:
        """Write what the replay showed into ``folder`` (``write_replay``)."""
        write_replay(folder, self.playback, self.verdict)

    def to_dict(self) -> dict[str, Any]:
        return {"valid": self.valid, "fixes_applied": list(self.fixes_applied),
                "errors": [f.to_dict() for f in self.errors], "domain": self.domain,
                "replay": self.replay}


def write_replay(folder: Path, playback: Playback | None, verdict: ReplayVerdict | None) -> None:
    """Write what a replay showed into a scenario folder: the playback (``replay.json``) and
    the judge's verdict on it (``verdict.json``); nothing of what is None."""
    if playback is not None:
        playback.write(Path(folder) / REPLAY_NAME)
    if verdict is not None:
        write_json_atomic(Path(folder) / VERDICT_NAME, verdict)


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

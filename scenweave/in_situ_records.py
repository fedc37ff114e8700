"""``scenweave run`` of mined records: beside each Town scenario, the event in situ.

A mined record (``scenweave mine``) names where it was found (``provenance``: the file, the
ego's track, the event's window). When a run makes a scenario of it, :class:`InSituWriter`
also writes the scenario folder's ``in_situ/`` (``mining.in_situ.write_in_situ``: the
recorded road and every vehicle recorded around the event, played in esmini and judged when
the run plays its scenarios). Each recording is read once per process and its road converted
once per content (cached in ``$SCENWEAVE_HOME/roads``). An event that cannot be played in situ
(its file gone, a track with a gap, a road that cannot be converted) gives one line naming the
file and the track or lanelet, kept in the scenario's ``status.json`` under ``in_situ``; the
Town scenario is not affected.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from scenweave.mining.in_situ import InSituSettings, RecordedRoad
    from scenweave.mining.tracks import Recording

__all__ = ["InSituWriter", "is_mined"]


def is_mined(record: Mapping[str, Any]) -> bool:
    """Whether a record says where in a recording it was found (a mined record)."""
    provenance = record.get("provenance")
    return isinstance(provenance, dict) and bool(provenance.get("file"))


class InSituWriter:
    """Writes the in-situ folder of mined records, reading each recording and road once."""

    def __init__(self, cache_dir: Path, play: bool) -> None:
        from scenweave.mining.in_situ import InSituSettings

        self.cache_dir = cache_dir
        self.settings: InSituSettings = InSituSettings(replay=play)
        self._recordings: dict[str, tuple[Recording, RecordedRoad] | str] = {}

    @classmethod
    def for_run(cls, play: bool) -> InSituWriter:
        from scenweave.agent.home import home

        return cls(home() / "roads", play)

    def _source(self, file: str) -> tuple[Recording, RecordedRoad] | str:
        """The recording and its road, or the line saying why there are none."""
        if file not in self._recordings:
            from scenweave.mining.in_situ import InSituRefused, recording_with_road

            try:
                self._recordings[file] = recording_with_road(file, self.cache_dir)
            except InSituRefused as err:
                self._recordings[file] = str(err)
        return self._recordings[file]

    def write(self, record: Mapping[str, Any], out_dir: Path) -> dict[str, Any]:
        """``out_dir/in_situ/`` for ``record``; what became of it (for ``status.json``)."""
        from scenweave.mining.in_situ import REFUSED_ERRORS, refusal, write_in_situ

        file = str(record["provenance"]["file"])
        try:
            source = self._source(file)
            if isinstance(source, str):
                return {"refused": source}
            result = write_in_situ(source[0], record, out_dir, source[1], self.settings)
        except REFUSED_ERRORS as err:  # one line naming the file (and the track); goes on
            return {"refused": refusal(err, file)}
        written: dict[str, Any] = {"vehicles": len(result.choice.vehicles),
                                   "timings_s": result.timings_s}
        if result.verdict is not None:
            overall = result.verdict.overall
            written.update(passed=result.verdict.passed,
                           position_share=round(overall.position_share, 5),
                           worst_position_m=round(overall.worst_position_m, 4))
        return written

"""``runs/<run_id>/``: one folder per scenario, a run description and ``summary.json``.

A scenario's files are written into a staging folder and moved into place with one rename,
so a scenario folder is either complete or absent; a rerun skips finished scenarios.
"""

from __future__ import annotations

import errno
import json
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from scenweave.files.atomic import write_json_atomic
from scenweave.schemas.scenario_folder import (
    STAGING_DIR,
    STATUS_NAME,
    Outcome,
    folder_damage,
    read_outcome,
)


def new_run_id() -> str:
    """A sortable id from the current UTC time, e.g. ``20261122-223015``."""
    return datetime.now(UTC).strftime("%Y%m%d-%H%M%S")


def safe_name(scenario_id: str) -> str:
    """The folder name of a scenario: its id with anything but ``[A-Za-z0-9_.-]`` replaced."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", scenario_id)


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run: the scenarios finished so far are kept; the message says how to
    resume."""

    def __init__(self, run_id: str, committed: int):
        super().__init__(f"interrupted after {committed} new scenarios of run {run_id}; they "
                         f"are kept: run the same command with --run-id {run_id} to resume")


@dataclass
class Started:
    """How far a run got in this process: scenario folders committed."""

    committed: int = 0


class RunFolder:
    """The files of one run."""

    def __init__(self, root: Path, created: bool = False):
        self.root = Path(root)
        #: this process made the folder (a resumed run's folder is not removed on failure)
        self.created = created
        #: the outcomes this process committed, by folder name, as their status.json reads
        #: back: the summary at the end of a batch reads no file it wrote itself
        self._committed: dict[str, Outcome] = {}

    @classmethod
    def open(cls, out_root: Path, run_id: str | None = None) -> RunFolder:
        """The run folder ``out_root/run_id`` (a new id when none is given), created if needed."""
        root = Path(out_root) / (run_id or new_run_id())
        folder = cls(root, created=not root.exists())
        folder.root.mkdir(parents=True, exist_ok=True)
        return folder

    @contextmanager
    def started(self) -> Iterator[Started]:
        """A run in this folder: if it stops before its first scenario, a folder it made is
        removed (no half-made run is left behind); staging leftovers go either way; Ctrl-C
        becomes :class:`RunInterrupted`, which says how to resume."""
        progress = Started()
        try:
            yield progress
        except BaseException as err:
            if self.created and progress.committed == 0 and not self.outcomes():
                _remove_tree(self.root)
            else:
                _remove_tree(self.root / STAGING_DIR)
            if isinstance(err, KeyboardInterrupt) and not isinstance(err, RunInterrupted) \
                    and self.root.exists():
                raise RunInterrupted(self.run_id, progress.committed) from err
            if isinstance(err, Exception) and self.root.exists():
                err.add_note(self.how_to_resume(err, progress))
            raise
        _remove_tree(self.root / STAGING_DIR)

    def announce(self) -> None:
        """One line on stderr as the run starts (also when it is not on a terminal, e.g. a
        log): which run, where, and the step that resumes it, at hand after a SIGKILL or an
        OOM kill, which leave no last words."""
        begun = "started" if self.created else "resumed"
        print(f"run {self.run_id}: {begun} in {self.root}; if it stops, the same command with "
              f"--run-id {self.run_id} resumes it", file=sys.stderr, flush=True)

    def how_to_resume(self, err: Exception, progress: Started) -> str:
        """What a run stopped by an error (a full disk, an LLM gone) with its folder kept adds
        to the error's one line (a note the command line prints with it): which run, where,
        how many scenarios are kept, and the one step that resumes it; a full disk names
        itself and says to free space first."""
        kept = len(self.outcomes())
        if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
            return (f"run {self.run_id} stopped: the disk holding {self.root} is full; "
                    f"{kept} scenarios are kept there ({progress.committed} new): free some "
                    f"space, then run the same command with --run-id {self.run_id} to resume")
        return (f"run {self.run_id} stopped ({type(err).__name__}) after {progress.committed} "
                f"new scenarios, {kept} in {self.root}; they are kept: run the same command "
                f"with --run-id {self.run_id} to resume")

    @property
    def run_id(self) -> str:
        return self.root.name

    def scenario_dir(self, scenario_id: str) -> Path:
        return self.root / safe_name(scenario_id)

    def outcome(self, scenario_id: str) -> Outcome | None:
        """The stored outcome of a finished scenario, or None."""
        return read_outcome(self.scenario_dir(scenario_id))

    def trusted_outcome(self, scenario_id: str) -> Outcome | None:
        """The stored outcome, or None when the folder lacks a file it names (or one cannot
        be read): then the scenario is made again, and one line on stderr says which and why
        (a resume after a kill, a full disk or a hand that deleted a file)."""
        outcome = self.outcome(scenario_id)
        why = folder_damage(self.scenario_dir(scenario_id), outcome) if outcome else None
        if why:
            print(f"run {self.run_id}: {scenario_id} is made again: {why}", file=sys.stderr,
                  flush=True)
            return None
        return outcome

    def staging(self, scenario_id: str) -> Path:
        """A fresh, empty staging folder for one scenario's files."""
        path = self.root / STAGING_DIR / safe_name(scenario_id)
        _remove_tree(path)
        path.mkdir(parents=True)
        return path

    def commit(self, scenario_id: str, staging: Path, outcome: dict) -> Path:
        """Write the outcome into ``staging`` and move the whole folder into place."""
        write_json_atomic(staging / STATUS_NAME, outcome)
        final = self.scenario_dir(scenario_id)
        if final.exists():
            _remove_tree(final)
        staging.rename(final)
        self._committed[final.name] = json.loads(json.dumps(outcome))
        return final

    def outcomes(self) -> list[Outcome]:
        """Every finished scenario's outcome, sorted by scenario id; those this process
        committed from memory, the others (an earlier run's) read from their folders."""
        return [outcome for path in sorted(self.root.glob(f"*/{STATUS_NAME}"))
                if (outcome := self._committed.get(path.parent.name)
                    or read_outcome(path.parent)) is not None]

    def write(self, name: str, data: Any) -> Path:
        path = self.root / name
        write_json_atomic(path, data)
        return path


def _remove_tree(path: Path) -> None:
    # rm -rf copes with trees too deep for shutil.rmtree (see notes/sandbox.md)
    if path.exists() or path.is_symlink():
        if shutil.which("rm"):
            subprocess.run(["rm", "-rf", "--", str(path)], check=True)
        else:
            shutil.rmtree(path)

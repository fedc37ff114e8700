"""Which process made a sandbox's host objects (run cgroups, containers), and whether it still
runs: what lets the next start sweep the leftovers of a process killed from outside, and
never touch those of a live one.

An owner is a pid with its start time (clock ticks after boot): together they name one
process even after the pid is reused.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

OWNER = re.compile(r"(\d+)-(\d+)")


def process_start(pid: int) -> int | None:
    """When ``pid`` started (clock ticks after boot), None when there is no such process."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return None
    return int(fields[19])  # field 22 of stat, counted after the command's ')'


def owner_tag(pid: int | None = None) -> str:
    """``<pid>-<start time>`` of ``pid`` (default: this process)."""
    pid = os.getpid() if pid is None else pid
    return f"{pid}-{process_start(pid)}"


def owner_gone(tag: str) -> bool:
    """Whether the process of ``tag`` (``owner_tag``) has ended; False for what is no tag."""
    match = OWNER.fullmatch(tag)
    if match is None:
        return False
    pid, start = map(int, match.groups())
    return process_start(pid) != start

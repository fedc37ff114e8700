"""Progress bars that show on a terminal and stay quiet in logs and CI."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")


def progress(items: Iterable[T], desc: str, total: int | None = None) -> Iterator[T]:
    """Iterate over ``items`` with a bar on stderr, only when stderr is a terminal."""
    yield from tqdm(items, desc=desc, total=total, disable=not sys.stderr.isatty(),
                    unit="rec", leave=False)

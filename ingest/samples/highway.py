"""Highway sample files: one ``<CLASS>_BINS_VALUES.npy`` per class, cells as strings.

Fields are drawn jointly, as in the real data (thesis §4.3, Fig. 4.16): final speeds follow
initial speeds, gaps follow speed through a time headway, braking depth follows intensity
and duration. The first rows of each file are edge cases a parser must get right.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenweave import maneuvers
from scenweave.ingest.layouts import ClassLayout, HighwayLayouts, load_layouts
from scenweave.maneuvers.sampling import sample_stream


def write_highway_samples(out_dir: Path, seed: int, per_class: int,
                          layouts: HighwayLayouts | None = None, phased: int = 0) -> list[Path]:
    """Write one file per highway class into ``out_dir`` (each class's generator,
    ``Maneuver.sample``); return the paths. ``phased`` more rows per class that has them
    (``Maneuver.sample_phased``: records a single speed ramp cannot show) follow the
    ``per_class`` rows, drawn from their own stream, so those rows stay the same."""
    layouts = layouts or load_layouts()
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for layout in _seeding_order(layouts):
        code, sample = layout.code, layout.maneuver.sample
        if sample is None:  # a (plugin) class without a generator has no sample data
            continue
        columns = sample(sample_stream(seed, code), per_class, code)
        rows = per_class
        if phased and layout.maneuver.sample_phased is not None:
            extra = layout.maneuver.sample_phased(sample_stream(seed, code, 1), phased, code)
            columns = {k: np.concatenate([v, extra[k]]) for k, v in columns.items()}
            rows += phased
        table = np.empty((rows, len(layout.columns)), dtype=object)
        for index, name in enumerate(layout.names):
            table[:, index] = _as_strings(columns[name])
        path = out_dir / f"{code}_BINS_VALUES.npy"
        np.save(path, table, allow_pickle=True)
        paths.append(path)
    return paths


def _seeding_order(layouts: HighwayLayouts) -> list[ClassLayout]:
    """The layouts in the registry's seeding order: adding a class never changes the rows
    drawn for the built-in ones."""
    order = [m.code for m in maneuvers.seeding_order("highway")]
    return sorted(layouts.classes.values(), key=lambda layout: order.index(layout.code))


def _as_strings(values: np.ndarray) -> np.ndarray:
    if values.dtype == object:
        return values
    return np.array([f"{v:.2f}".rstrip("0").rstrip(".") if v != int(v) else f"{v:.1f}"
                     for v in values], dtype=object)

"""Finding the MOOVE classes' events in a recording of a whole road: every detector of
``mining.highway`` and ``mining.lights`` over one :class:`Scene`."""

from __future__ import annotations

from collections.abc import Callable, Iterator

from scenweave.mining import highway, lights, urban
from scenweave.mining.scene import KMH, Event, Scene
from scenweave.mining.tracks import Recording

__all__ = ["DETECTORS", "KMH", "Event", "Scene", "detect"]


def detect(recording: Recording, thresholds: dict[str, dict[str, float]]) -> list[Event]:
    """Every event of every detector, sorted by start time and class."""
    scene = Scene(recording, thresholds)
    events = [event for detector in DETECTORS for event in detector(scene)]
    return sorted(events, key=lambda e: (e.start_s, e.code, e.ego))


DETECTORS: tuple[Callable[[Scene], Iterator[Event]], ...] = (
    highway.braking_leads, highway.cuts, highway.own_lane_changes, highway.following,
    highway.free_rides, lights.light_events, urban.urban_events)

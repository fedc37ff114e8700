"""Mining manoeuvres from public trajectory data: readers turn each format into
:class:`Recording`\\ s of :class:`Track`\\ s; detection finds the MOOVE classes' events in them
and writes each as a canonical record (``scenweave mine``)."""

from scenweave.mining.tracks import LightPhase, Recording, Track, TrafficLight

__all__ = ["LightPhase", "Recording", "Track", "TrafficLight"]

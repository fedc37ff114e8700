"""Every entity's state at every step, recorded in bulk in the player's child process.

Recording a state as Python values at each step (a ``getattr``, a ``round`` and a list append
per field, entity and step) cost about as much as esmini's own stepping: 28 ms of a 40 ms
``step`` for a three-car scenario of 20 s on a loaded machine. Here each step only asks esmini
to copy each entity's ``SE_ScenarioObjectState`` into the next slot of one growing C array
(one library call per entity, no Python object per field); the columns are cut out of that
memory once, after the last step, with strided ``memoryview`` slices, and rounded as
``Playback.add_state`` rounds them, so the playback is the same value for value.
"""

from __future__ import annotations

import ctypes
from typing import Any, Literal

from scenweave.player.playback import NO_JUNCTION, TRACK_FIELDS, Box, Playback

#: esmini's ``SE_ScenarioObjectState`` fields the tracks keep, by track field (``TRACK_FIELDS``)
STATE_FIELDS = {"x": "x", "y": "y", "z": "z", "h": "h", "speed": "speed", "road": "roadId",
                "lane": "laneId", "s": "s", "lane_offset": "laneOffset",
                "junction": "junctionId"}
#: ``struct`` formats of the integer fields (the rest are doubles)
_FORMATS: dict[str, Literal["I", "i"]] = {"road": "I", "junction": "I", "lane": "i"}
#: states the buffer holds at first, per entity (a 60 s scenario at 0.05 s: 1,201 steps)
INITIAL_STEPS = 256
#: at most this many steps are set aside before the scenario shows it needs them (the buffer
#: doubles when full): an hour-long stop time must not cost 14 MB per entity up front
MAX_INITIAL_STEPS = 4096


class StateRecorder:
    """The states of ``ids`` (esmini object ids, named ``names``) at each ``record()``.

    ``state_type`` is the ``ctypes.Structure`` laid out as ``SE_ScenarioObjectState``; the
    library's ``SE_GetObjectState`` must take the state's address as ``c_void_p``.
    """

    def __init__(self, lib: Any, state_type: type[ctypes.Structure], ids: list[int],
                 names: dict[int, str], steps: int = INITIAL_STEPS) -> None:
        self.lib, self.state_type, self.ids, self.names = lib, state_type, ids, names
        self.size = ctypes.sizeof(state_type)
        if self.size % 8:
            raise ValueError(f"{state_type.__name__} is {self.size} bytes, not whole doubles")
        self.states = (state_type * max(1, steps * len(ids)))()
        self.used = 0
        self.times: list[float] = []
        self.collisions: list[tuple[float, int, int]] = []

    def record(self) -> None:
        """Copy every entity's state and its collisions at esmini's current time."""
        lib = self.lib
        now = lib.SE_GetSimulationTime()
        self.times.append(now)
        if self.used + len(self.ids) > len(self.states):
            self._grow()
        address = ctypes.addressof(self.states) + self.used * self.size
        for object_id in self.ids:
            lib.SE_GetObjectState(object_id, address)
            address += self.size
            for k in range(lib.SE_GetObjectNumberOfCollisions(object_id)):
                self.collisions.append((now, object_id, lib.SE_GetObjectCollision(object_id, k)))
        self.used += len(self.ids)

    def _grow(self) -> None:
        bigger = (self.state_type * (2 * len(self.states)))()
        ctypes.memmove(bigger, self.states, self.used * self.size)
        self.states = bigger

    def playback(self) -> Playback:
        """The recorded steps as a ``Playback`` (tracks, boxes, collisions, times)."""
        playback = Playback.empty(self.names[i] for i in self.ids)
        playback.times = [round(t, 4) for t in self.times]
        memory = memoryview(self.states).cast("B")[:self.used * self.size]
        for index, object_id in enumerate(self.ids):
            name = self.names[object_id]
            playback.tracks[name] = self._track(memory, index)
            if self.used:
                first = self.states[index]
                playback.boxes[name] = Box(round(first.length, 4), round(first.width, 4),
                                           round(first.centerOffsetX, 4))
        for time_s, object_id, other_id in self.collisions:
            other = self.names.get(other_id)
            if other is not None:
                playback.add_collision(round(time_s, 4), self.names[object_id], other)
        return playback

    def _track(self, memory: memoryview, index: int) -> dict[str, list[float]]:
        """Entity ``index``'s columns: every ``len(ids)``-th state from its first one (the
        state's size is a multiple of 8, so every field lies on a whole stride)."""
        stride = len(self.ids) * self.size
        track: dict[str, list[float]] = {}
        for key in TRACK_FIELDS:
            field = getattr(self.state_type, STATE_FIELDS[key])
            column = memory[index * self.size + field.offset:]
            column = column[:len(column) - len(column) % field.size]
            typed = column.cast(_FORMATS[key]) if key in _FORMATS else column.cast("d")
            numbers: list[Any] = typed[::stride // field.size].tolist()
            if key == "junction":
                track[key] = [-1 if v == NO_JUNCTION else v for v in numbers]
            elif key in ("road", "lane"):
                track[key] = numbers
            else:
                track[key] = [round(v, 4) for v in numbers]
        return track

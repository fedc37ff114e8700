"""The road a recording was made on (CommonRoad XML, highD), as an OpenDRIVE file:
converted once per file content and cached, with what a scenario on it needs (lanelet ->
road and lane, lights -> signals and their recorded cycles).

``road_for(source, cache_dir)`` is the entry point. The cache entry is a folder named by the
sha256 of the source file's bytes (with highD's recordingMeta) and :data:`CACHE_VERSION`,
holding ``road.xodr`` and ``road.json`` (written last, atomically: a folder without it is
incomplete and rewritten). A network that cannot be converted raises
:class:`RecordedRoadError` naming the file and the lanelet.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lxml import etree

from scenweave.files.atomic import write_bytes_atomic, write_json_atomic
from scenweave.mining.readers.lanelet_map import LaneletMap, companions, read_road_network
from scenweave.mining.tracks import LightPhase
from scenweave.roads.errors import RecordedRoadError
from scenweave.roads.recorded_road import CONVERTER_VERSION, ConvertedRoad, convert

#: the reader's share of the cache key: bump when the strips read from a file change
READER_VERSION = "1"
CACHE_VERSION = f"{CONVERTER_VERSION}.{READER_VERSION}"
XODR_NAME = "road.xodr"
META_NAME = "road.json"
#: what a malformed file makes the XML parser or commonroad-io raise (it checks with assert)
READ_ERRORS = (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError,
               AssertionError, etree.XMLSyntaxError)


@dataclass(frozen=True)
class SignalLight:
    """One recorded traffic light on the map: the OpenDRIVE signals standing for it (one per
    lane it governs) and its recorded colours, for a TrafficSignalController."""

    light_id: str
    signal_ids: tuple[str, ...]
    phases: tuple[LightPhase, ...]
    #: the lanelets it governs, as the recording names them
    lanelets: tuple[str, ...] = ()


@dataclass(frozen=True)
class RecordedRoadMap:
    """A recording's road as OpenDRIVE and how to address it."""

    source: str
    xodr: Path
    #: lanelet id (as the recording's tracks name lanes) -> (OpenDRIVE road id, lane id)
    lanes: dict[str, tuple[int, int]]
    lights: tuple[SignalLight, ...]
    #: lanelet links the map could not express ("from->to")
    unlinked: tuple[str, ...] = ()
    cached: bool = False

    def to_json(self) -> dict[str, Any]:
        """What the cache's ``road.json`` holds (everything but the paths)."""
        return {"source": self.source, "cache_version": CACHE_VERSION,
                "lanes": {k: list(v) for k, v in self.lanes.items()},
                "lights": [{"light_id": light.light_id, "signal_ids": list(light.signal_ids),
                            "lanelets": list(light.lanelets),
                            "phases": [[p.start_s, p.end_s, p.state] for p in light.phases]}
                           for light in self.lights],
                "unlinked": list(self.unlinked)}

    @classmethod
    def from_json(cls, data: dict[str, Any], xodr: Path, source: Path) -> RecordedRoadMap:
        """The entry a cache holds, for ``source`` (a file of the same content may have
        made it under another name)."""
        lights = tuple(SignalLight(str(d["light_id"]), tuple(d["signal_ids"]),
                                   tuple(LightPhase(float(a), float(b), str(c))
                                         for a, b, c in d["phases"]),
                                   tuple(d.get("lanelets", ())))
                       for d in data["lights"])
        return cls(source=str(source), xodr=xodr,
                   lanes={k: (int(v[0]), int(v[1])) for k, v in data["lanes"].items()},
                   lights=lights, unlinked=tuple(data.get("unlinked", ())), cached=True)


def cache_key(content: bytes) -> str:
    """The cache folder's name for a source file's bytes."""
    digest = hashlib.sha256(content)
    digest.update(b"\0recorded-road " + CACHE_VERSION.encode())
    return digest.hexdigest()[:32]


def read_network(source: Path) -> LaneletMap:
    """The file's lane network (CommonRoad XML, highD); :class:`RecordedRoadError` naming
    the file where it cannot be read."""
    try:
        return read_road_network(source)
    except READ_ERRORS as err:
        raise RecordedRoadError(f"{source}: not a readable lane network: {err}") from err


def converted(lanelet_map: LaneletMap) -> ConvertedRoad:
    """The lane network as OpenDRIVE; :class:`RecordedRoadError` naming the file and the
    lanelet where it cannot be made."""
    try:
        return convert(lanelet_map.strips, lanelet_map.lights,
                       name=Path(lanelet_map.source).stem)
    except RecordedRoadError as err:
        raise RecordedRoadError(f"{lanelet_map.source}: {err}") from err


def _road_map(lanelet_map: LaneletMap, road: ConvertedRoad, xodr: Path) -> RecordedRoadMap:
    lights = tuple(SignalLight(light.id, road.signal_ids(light.id),
                               lanelet_map.phases.get(light.id, ()), light.strips)
                   for light in lanelet_map.lights)
    return RecordedRoadMap(source=lanelet_map.source, xodr=xodr, lanes=dict(road.lanes),
                           lights=lights, unlinked=road.unlinked)


def road_for(source: Path, cache_dir: Path) -> RecordedRoadMap:
    """The recording's road as ``road.xodr`` under ``cache_dir``, converted on the first call
    for this file content and read back from the cache after."""
    source = Path(source)
    try:
        content = b"".join(p.read_bytes() for p in (source, *companions(source)))
    except OSError as err:
        raise RecordedRoadError(f"{source}: cannot be read: {err.strerror or err}") from err
    folder = Path(cache_dir) / cache_key(content)
    xodr, meta = folder / XODR_NAME, folder / META_NAME
    if meta.is_file() and xodr.is_file():
        try:
            return RecordedRoadMap.from_json(json.loads(meta.read_text(encoding="utf-8")), xodr,
                                          source)
        except (ValueError, KeyError, TypeError):
            pass  # a damaged entry is made again
    lanelet_map = read_network(source)
    road = converted(lanelet_map)
    result = _road_map(lanelet_map, road, xodr)
    write_bytes_atomic(xodr, road.xodr)
    write_json_atomic(meta, result.to_json())
    return result

"""SpawnMatcher: choose where a scenario starts (thesis §5.2, Table 5.3, plus manoeuvre fit).

Two phases. Hard filters reject spawn points that cannot host the scenario: wrong context, on
a junction, (highway) an intersection or light nearby, (urban) no light where the manoeuvre
needs one or a manoeuvre not in ``suitable_for``; and, beyond the thesis, the manoeuvre must
fit: a same-direction lane on every side ``required_lane_sides`` names, for as long as the
manoeuvre lasts, and enough drivable lane ahead for the gap plus the distance the fastest
actor travels until the stop trigger, and behind for the gap to the rearmost actor; on the
highway no signalised junction until the manoeuvre ends (until the stop trigger where the map
has such spawns), and a lane change whose lane keeps its id throughout. The
survivors are scored with Table 5.3 and ranked (urban manoeuvres without a light get the
light-distance points for room to drive before the next light instead); ``assign`` picks candidate
``index % len(candidates)`` (round robin) and fills the params' spawn keys in the
OpenSCENARIO frame (``y = -y_carla``, ``h = -radians(yaw_carla)``).

Every highway NPC is placed where it stands at t = 0: its recorded gap holds at
``maneuver_start_s`` (when it cuts in, brakes, ...), and until then both cars hold their start
speeds, so at t = 0 it stands ``scenario_lib.kinematics.start_gap_m`` ahead of the ego, measured
along its lane (on a curve a straight shift would leave the lane).
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any, TypedDict, cast

from scenweave import maneuvers
from scenweave.errors import ParamsError
from scenweave.roads.bundled import DEFAULT_MAP_PATH, road_network
from scenweave.roads.errors import LaneEndsError, OpenDriveError
from scenweave.roads.map_ref import MapRef, resolve_map
from scenweave.roads.road_network import LaneKey, LanePoint, RoadNetwork
from scenweave.roads.signals import junction_approach
from scenweave.scenario_lib.kinematics import lane_change_length_m, start_gap_m
from scenweave.scenario_lib.vehicles import ego_front_m
from scenweave.schemas.params import NumberReader, Params, actor_value, unchecked
from scenweave.spawn_db.database import (
    DEFAULT_DB_PATH,
    load_database,
    spawn_database,
    suits_urban,
)
from scenweave.spawn_db.errors import NoSpawnFits, SpawnDatabaseError

#: length of a vehicle plus a little room, added to every required drivable length (m)
VEHICLE_MARGIN_M = 6.0
#: the right turn ends this far into the lane the right movement leads to (m)
TURN_EXIT_INTO_M = 10.0
#: the junction a right turn crosses must start within this distance of the spawn (m)
TURN_SEARCH_M = 500.0
TURN_EXIT_KEYS = tuple(f"turn_exit_{key}" for key in ("x", "y", "z", "h", "road_id", "lane_id",
                                                      "s"))
#: most points ``_needs_score`` gives: the speed (limit) proximity, and for urban scenarios
#: the light distance (or room before the next light) plus the stop line
NEEDS_POINTS_MAX = {"highway": 20.0, "urban": 20.0 + 30.0 + 15.0}
#: free-ride slots and the lane each stands in relative to the ego
FREE_RIDE_SLOTS = {"center": None, "right": "right", "left": "left"}
#: lane walks for the lane-change check are made (and kept) this long at least (m)
LANE_PATH_M = 500.0
#: the params prefix of each lane changer (``Maneuver.lane_change``) for its speeds
PREFIX_OF_CHANGER = {"npc": "npc", "hero": "ego"}


@dataclass(frozen=True)
class Rejection:
    """Why one spawn point cannot host the scenario: the constraint and the numbers."""

    constraint: str
    detail: str

    def __str__(self) -> str:
        return f"{self.constraint}: {self.detail}"


class Transform(TypedDict):
    """A spawn point's pose in CARLA's frame (``spawn_db.schema.json``)."""

    x: float
    y: float
    z: float
    yaw: float


#: a lane walk: ``(road, lane, from, to)`` metres of each lane section walked
LanePath = list[tuple[str, int, float, float]]


@dataclass(frozen=True)
class SpawnCandidate:
    """A spawn point that passed the hard filters, with its score and OpenSCENARIO pose."""

    spawn_id: int
    score: float
    entry: dict[str, Any] = field(repr=False)

    @property
    def transform(self) -> Transform:
        """The spawn's pose in CARLA's frame."""
        transform: Transform = self.entry["transform"]
        return transform

    @property
    def x(self) -> float:
        """OpenSCENARIO x (= CARLA x)."""
        return self.transform["x"]

    @property
    def y(self) -> float:
        """OpenSCENARIO y = -y_carla."""
        return -self.transform["y"]

    @property
    def z(self) -> float:
        """Height (same in both frames)."""
        return self.transform["z"]

    @property
    def h(self) -> float:
        """OpenSCENARIO heading = -radians(yaw_carla)."""
        return -math.radians(self.transform["yaw"])

    @property
    def lane_point(self) -> LanePoint:
        """Road, lane and ``s`` of the spawn point."""
        geometry = self.entry["geometry"]
        return LanePoint(str(geometry["road_id"]), geometry["lane_id"], geometry["s"])


@dataclass(frozen=True)
class Assessment:
    """One spawn point judged against one scenario: its score, or why it was rejected."""

    spawn_id: int
    score: float
    rejections: tuple[Rejection, ...]

    @property
    def accepted(self) -> bool:
        """Whether the spawn point passed every hard filter."""
        return not self.rejections


@dataclass(frozen=True)
class Requirements:
    """What a scenario asks of its spawn point, derived from its params."""

    scenario_id: str
    domain: str
    tag: str
    sides: tuple[str, ...]
    ahead_m: float
    behind_m: float
    side_ahead_m: float
    side_behind_m: float
    speed_kmh: float
    speed_limit_kmh: float | None
    tfl_ds_m: float | None
    drive_distance_m: float | None = None
    #: the movement whose light the manoeuvre plays with (``None``: no light needed); a right
    #: turn also gets the exit of its movement (``turn_exit_*`` keys)
    light_movement: str | None = None
    #: metres ahead that must have no signalised junction (highway): the whole drive until
    #: the stop trigger, or (``lights_after_manoeuvre``) until the manoeuvre ends
    light_free_m: float = 0.0
    #: a class that passes its stop line: the farthest the line may lie ahead of the spawn,
    #: the recorded drive less the ego's front (``None``: no line to pass, or no drive known)
    stop_line_within_m: float | None = None

    @classmethod
    def from_params(cls, params: Params) -> Requirements:
        """Read the contract keys (docs/params.md) the matcher needs."""
        scenario_id = str(params.get("scenario_id", "<no scenario_id>"))
        number = NumberReader(params)
        domain = params.get("domain")
        if domain not in ("highway", "urban"):
            raise ParamsError(f"{scenario_id}: domain must be 'highway' or 'urban', got {domain!r}")
        sides = tuple(params.get("required_lane_sides") or ())
        if any(side not in ("left", "right") for side in sides):
            raise ParamsError(f"{scenario_id}: required_lane_sides must hold 'left'/'right', "
                              f"got {list(sides)!r}")
        max_speed = number("max_speed_ms")
        # the oncoming car is placed wherever the other direction's lane is, not on the route
        starts = [distance for _, side, distance in _placed_actors(params) if side != ONCOMING]
        gap_ahead = max(number("gap_ahead_m"), *starts, 0.0)
        gap_behind = max(number("gap_behind_m"), *(-d for d in starts), 0.0)
        manoeuvre_end = number("maneuver_start_s", 0.0) + number("duration_s", 0.0)
        ahead = gap_ahead + max_speed * number("timeout_s") + VEHICLE_MARGIN_M
        return cls(
            scenario_id=scenario_id, domain=domain, tag=str(params.get("maneuver_tag", "")),
            sides=sides, ahead_m=ahead, behind_m=gap_behind + VEHICLE_MARGIN_M,
            side_ahead_m=min(ahead, gap_ahead + max_speed * manoeuvre_end + VEHICLE_MARGIN_M),
            side_behind_m=gap_behind + VEHICLE_MARGIN_M, speed_kmh=max_speed * 3.6,
            speed_limit_kmh=number.optional("speed_limit_kmh"),
            tfl_ds_m=number.optional("tfl_ds_m"),
            drive_distance_m=number.optional("drive_distance_m"),
            light_movement=_light_movement(params) if domain == "urban" else None,
            light_free_m=ahead, stop_line_within_m=_stop_line_within_m(params))

    def lights_after_manoeuvre(self) -> Requirements:
        """These needs with a light allowed on the route once the manoeuvre has ended.

        A map whose highways end at signalised junctions every kilometre (Town06) has no
        spawn light-free for the whole drive of a long record (the stop trigger comes at 2.5x
        the manoeuvre's end); the record's manoeuvre must still never meet one.
        """
        return replace(self, light_free_m=self.side_ahead_m)



def _maneuver_of(params: Params) -> maneuvers.Maneuver | None:
    return maneuvers.find(params.get("maneuver_class")) or maneuvers.by_tag(
        str(params.get("maneuver_tag", "")))


def _light_movement(params: Params) -> str | None:
    maneuver = _maneuver_of(params)
    return None if maneuver is None or maneuver.light is None else maneuver.turn


def _stop_line_within_m(params: Params) -> float | None:
    """How far ahead of the spawn the stop line of a class that passes it may lie: the
    recorded drive less the ego's front, so the ego crosses the line it crossed in the
    record (else the replay's REPLAY_NO_PASS: issue 36)."""
    maneuver, drive = _maneuver_of(params), NumberReader(params).optional("drive_distance_m")
    if params.get("domain") != "urban" or maneuver is None or maneuver.light is None \
            or maneuver.stops_at_line or drive is None:
        return None
    return drive - ego_front_m()


class SpawnMatcher:
    """Ranks the spawn points of a database for a params dict and assigns one."""

    def __init__(self, db_path: str | Path = DEFAULT_DB_PATH,
                 map_path: str | Path | None = None):
        self.db_path = Path(db_path)
        self.database = load_database(self.db_path)
        self.entries: list[dict[str, Any]] = self.database["spawn_points"]
        self.map_path = Path(map_path) if map_path else self._find_map()
        #: the map the spawns stand on; ``assign`` names it in the params (key ``map``)
        self.map = resolve_map(self.map_path)
        #: per context, ``(fixed score, entry)`` best first: ``find`` stops early down this list
        self._by_context: dict[str, list[tuple[float, dict[str, Any]]]] = {}
        for entry in self.entries:
            self._by_context.setdefault(entry["context"], []).append((_fixed_score(entry), entry))
        for ranked in self._by_context.values():
            ranked.sort(key=lambda pair: (-pair[0], pair[1]["spawn_id"]))
        self._last_params: Params | None = None
        #: lane walks of ``_lane_path``: start -> (metres walked, walk ended, path)
        self._lane_paths: dict[tuple[str, int, float], tuple[float, bool, LanePath]] = {}

    @classmethod
    def for_map(cls, map_ref: MapRef, cache_dir: Path) -> SpawnMatcher:
        """The matcher of ``map_ref``'s spawn database (built and cached on first use)."""
        return cls(spawn_database(map_ref, cache_dir), map_ref.path)

    def _find_map(self) -> Path:
        source: str = self.database["metadata"]["source_map"]
        for candidate in (self.db_path.parent / "maps" / source, self.db_path.parent / source):
            if candidate.exists():
                return candidate
        if source == DEFAULT_MAP_PATH.name:
            return DEFAULT_MAP_PATH
        raise SpawnDatabaseError(f"{self.db_path}: its map {source} is neither in maps/ beside "
                                 "it nor bundled; pass map_path= to SpawnMatcher")

    @cached_property
    def network(self) -> RoadNetwork:
        """The lane graph of the database's map (loaded on first use, then kept)."""
        return road_network(self.map_path)

    @property
    def last_rejections(self) -> dict[int, tuple[Rejection, ...]]:
        """Why each spawn point was rejected in the last ``find``, by spawn id (debugging)."""
        if self._last_params is None:
            return {}
        return {a.spawn_id: a.rejections for a in self.assess(self._last_params)
                if not a.accepted}

    def assess(self, params: Params) -> list[Assessment]:
        """Every spawn point judged against ``params``, in database order."""
        return self._assess(Requirements.from_params(params), params)

    def _assess(self, needs: Requirements, params: Params) -> list[Assessment]:
        assessments = []
        for entry in self.entries:
            rejections = tuple(_hard_filters(entry, needs)) or self._route_rejections(entry,
                                                                                      params)
            score = -1.0 if rejections else _score(entry, needs)
            assessments.append(Assessment(entry["spawn_id"], score, rejections))
        return assessments

    def find(self, params: Params, top_n: int = 5) -> list[SpawnCandidate]:
        """The ``top_n`` best spawn points for ``params``, best first.

        Raises :class:`NoSpawnFits` naming the constraint that ruled most spawn points out.
        """
        if top_n < 1:
            raise ParamsError(f"top_n must be at least 1, got {top_n}")
        needs = Requirements.from_params(params)
        self._last_params = unchecked(dict(params))
        accepted = self._accepted(needs, params, top_n)
        if not accepted and needs.domain == "highway":
            # prefer a drive free of lights to the stop trigger, need one to the manoeuvre's end
            needs = needs.lights_after_manoeuvre()
            accepted = self._accepted(needs, params, top_n)
        if not accepted:
            raise NoSpawnFits(_no_fit_message(params, self.map.name, self._assess(needs, params)))
        return _spread_over_roads(accepted)[:top_n]

    def _accepted(self, needs: Requirements, params: Params,
                  top_n: int) -> list[SpawnCandidate]:
        """The spawn points passing every filter, as far down the ranking as the top N go."""
        accepted: list[SpawnCandidate] = []
        top_scores: list[float] = []  # a min-heap of the best top_n scores
        for fixed, entry in self._by_context.get(needs.domain, []):
            if len(top_scores) == top_n and fixed + NEEDS_POINTS_MAX[needs.domain] < top_scores[0]:
                break  # neither this spawn nor any after it can reach (or tie) the top N
            # only the first rejection matters here; assess() lists them all for debugging
            if next(_hard_filters(entry, needs), None) is not None:
                continue
            score = fixed + _needs_score(entry, needs)
            if len(top_scores) == top_n and score < top_scores[0]:
                continue  # N better ones are in: it cannot make the top N, so skip the walk
            if self._route_rejections(entry, params):
                continue
            accepted.append(SpawnCandidate(entry["spawn_id"], score, entry))
            (heapq.heappush if len(top_scores) < top_n else heapq.heappushpop)(top_scores, score)
        return accepted

    def assign(self, params: Params, index: int, top_n: int = 5) -> Params:
        """A new params dict with the spawn keys filled from candidate ``index % len``."""
        candidates = self.find(params, top_n)
        return self.place(params, candidates[index % len(candidates)])

    def spawns_beside(self, placed: Params) -> list[SpawnCandidate]:
        """The spawn points one lane over from ``placed`` (params ``assign`` filled): in each
        same-direction lane beside the ego's on the same road, the one nearest the ego's ``s``
        that fits the scenario, the nearer first (left on a tie). What a lane variant is
        placed from (``ingest.variants``).

        Raises :class:`NoSpawnFits` when neither neighbouring lane has such a spawn point.
        """
        needs = Requirements.from_params(placed)
        here, ego_s = self._ego_lane(placed, needs)
        ego = LanePoint(here.road_id, here.lane_id, ego_s)
        lanes = {(neighbour.road_id, neighbour.lane_id): side for side in ("left", "right")
                 if (neighbour := self.network.neighbour(here, side)) is not None}
        nearest: dict[tuple[str, int], tuple[float, int, dict[str, Any]]] = {}
        for _, entry in self._by_context.get(needs.domain, []):
            lane = (str(entry["geometry"]["road_id"]), entry["geometry"]["lane_id"])
            if lane not in lanes:
                continue
            found = (abs(entry["geometry"]["s"] - ego.s), list(lanes).index(lane), entry)
            if found[:2] < nearest.get(lane, (math.inf, 0))[:2] and self._fits(entry, needs,
                                                                                placed):
                nearest[lane] = found
        if not nearest:
            beside = ", ".join(f"{side}: lane {lane}" for (_, lane), side in lanes.items())
            raise NoSpawnFits(f"{needs.scenario_id}: no spawn point beside road {ego.road_id} "
                              f"lane {ego.lane_id} on map {self.map.name} fits the scenario "
                              f"({beside or 'no same-direction lane beside it'})")
        return [SpawnCandidate(entry["spawn_id"], _score(entry, needs), entry)
                for *_, entry in sorted(nearest.values(), key=lambda found: found[:2])]

    def lane_free_of_record(self, placed: Params, ahead_m: float,
                            index: int = 0) -> LanePoint:
        """A point ``ahead_m`` ahead of the ego along a same-direction lane that no actor of
        ``placed`` starts in or moves into (``required_lane_sides``), with drivable lane for a
        vehicle driving the ego's start speed until the stop trigger: where another vehicle
        keeps clear of the record (``ingest.variants``). The free lanes are ranked nearest
        the ego first (left on a tie); ``index`` picks one, the next where a lane ends.

        Raises :class:`NoSpawnFits` when no lane beside the ego is free for it.
        """
        needs = Requirements.from_params(placed)
        number = NumberReader(placed)
        here, ego_s = self._ego_lane(placed, needs)
        used = {(str(actor_value(placed, actor, "road_id")), actor_value(placed, actor, "lane_id"))
                for actor in ("ego", *(name for name, _, _ in _placed_actors(placed)))}
        used |= {(key.road_id, key.lane_id) for side in needs.sides
                 if (key := self.network.neighbour(here, side)) is not None}
        needed = ahead_m + number("ego_speed_ms") * number("timeout_s") + VEHICLE_MARGIN_M
        free = [key for key in self._lanes_beside(here) if (key.road_id, key.lane_id) not in used]
        for offset in range(len(free)):
            key = free[(index + offset) % len(free)]
            try:
                point = self.network.advance(key.road_id, key.lane_id, ego_s, ahead_m)
            except LaneEndsError:
                continue
            if self.network.drivable_length(point.road_id, point.lane_id, point.s, True,
                                            needed) >= needed - ahead_m:
                return point
        raise NoSpawnFits(f"{needs.scenario_id}: no lane beside road {here.road_id} lane "
                          f"{here.lane_id} on map {self.map.name} is free of the record for "
                          f"{needed:.0f} m (lanes the record uses: "
                          f"{', '.join(str(lane) for _, lane in sorted(used, key=str))})")

    def actor_keys(self, actor: str, point: LanePoint) -> dict[str, Any]:
        """The params keys of ``actor`` standing at ``point``: its world pose (OpenSCENARIO
        frame) and its lane position, as ``assign`` writes them."""
        pose = self.network.lane_to_world(point.road_id, point.lane_id, point.s)
        return {**_pose_keys(actor, pose.x, pose.y, pose.z, pose.h), **_lane_keys(actor, point)}

    def _ego_lane(self, placed: Params, needs: Requirements) -> tuple[LaneKey, float]:
        """The ego's lane and ``s`` where the spawn stage placed it."""
        lane, s = actor_value(placed, "ego", "lane_id"), actor_value(placed, "ego", "s")
        try:
            if lane is None or s is None:
                raise KeyError("ego_lane_id" if lane is None else "ego_s")
            return self.network.key_at(str(actor_value(placed, "ego", "road_id")), lane, s), s
        except (KeyError, TypeError, ValueError, OpenDriveError) as err:
            raise ParamsError(f"{needs.scenario_id}: ego_road_id/ego_lane_id/ego_s do not name "
                              f"a lane of map {self.map.name}: {err}") from err

    def _lanes_beside(self, here: LaneKey) -> list[LaneKey]:
        """Every same-direction lane beside ``here``, nearest first (left before right)."""
        found = []
        for side in ("left", "right"):
            key, steps = self.network.neighbour(here, side), 0
            while key is not None:
                steps += 1
                found.append((steps, side == "right", key))
                key = self.network.neighbour(key, side)
        return [key for *_, key in sorted(found, key=lambda item: item[:2])]

    def named_spawn(self, params: Params) -> SpawnCandidate:
        """The spawn point ``params`` name (``spawn_id``), when it still fits them: for a
        record whose values changed but whose place did not (a variant with another vehicle
        model, whose reference-point gaps differ). Raises :class:`NoSpawnFits` otherwise."""
        needs = Requirements.from_params(params)
        entry = next((e for _, e in self._by_context.get(needs.domain, [])
                      if e["spawn_id"] == params.get("spawn_id")), None)
        if entry is None or not self._fits(entry, needs, params):
            why = "not in its database" if entry is None else self._why_not(entry, needs, params)
            raise NoSpawnFits(f"{needs.scenario_id}: spawn point {params.get('spawn_id')} of map "
                              f"{self.map.name} does not fit the changed scenario ({why})")
        return SpawnCandidate(entry["spawn_id"], _score(entry, needs), entry)

    def place(self, params: Params, candidate: SpawnCandidate) -> Params:
        """``params`` with the spawn keys filled from ``candidate`` (as ``assign`` fills them
        from its pick)."""
        return cast(Params, self._placed(params, candidate))  # the params with the spawn keys

    def _why_not(self, entry: dict[str, Any], needs: Requirements,
                 params: Params) -> str:
        rejections = (*_hard_filters(entry, needs), *self._route_rejections(entry, params))
        return str(rejections[0]) if rejections else "no reason found"

    def _fits(self, entry: dict[str, Any], needs: Requirements, params: Params) -> bool:
        if next(_hard_filters(entry, needs), None) is None and not self._route_rejections(entry,
                                                                                         params):
            return True
        relaxed = needs.lights_after_manoeuvre()  # as ``find`` falls back to
        return (needs.domain == "highway" and next(_hard_filters(entry, relaxed), None) is None
                and not self._route_rejections(entry, params))

    def _placed(self, params: Params, candidate: SpawnCandidate) -> dict[str, Any]:
        """``params`` with the spawn keys filled from ``candidate``; :class:`NoSpawnFits` when
        an actor's lane ends before its place (the road model's ``LaneEndsError``)."""
        try:
            return self._filled(params, candidate)
        except LaneEndsError as err:
            raise NoSpawnFits(f"{params.get('scenario_id')}: spawn point {candidate.spawn_id} "
                              f"of map {self.map.name}: {err}") from err

    def _filled(self, params: Params, candidate: SpawnCandidate) -> dict[str, Any]:
        result = dict(params)
        result["map"] = self.map.logic_file
        result["spawn_id"] = candidate.spawn_id
        ego = candidate.lane_point
        result.update(_pose_keys("ego", candidate.x, candidate.y, candidate.z, candidate.h))
        result.update(_lane_keys("ego", ego))
        for actor, side, distance in _placed_actors(params):
            point = self._place(ego, side, distance, params)
            pose = self.network.lane_to_world(point.road_id, point.lane_id, point.s)
            result.update(_pose_keys(actor, pose.x, pose.y, pose.z, pose.h))
            result.update(_lane_keys(actor, point))
            result[f"{actor}_in_junction"] = self.network.road(point.road_id).in_junction
        if params.get("domain") == "urban":
            needs = Requirements.from_params(params)
            result.update(_light_keys(candidate.entry, needs))
            result.update(self._turn_exit_keys(ego, needs))
        return result

    def _turn_exit_keys(self, ego: LanePoint, needs: Requirements) -> dict[str, Any]:
        """``turn_exit_*``: where a right turn from the spawn ends (``None`` for other tags)."""
        keys: dict[str, Any] = dict.fromkeys(TURN_EXIT_KEYS)
        if needs.light_movement != "right":
            return keys
        point = self.right_turn_exit(ego, needs.scenario_id)
        pose = self.network.lane_to_world(point.road_id, point.lane_id, point.s)
        keys.update(_pose_keys("turn_exit", pose.x, pose.y, pose.z, pose.h))
        keys.update(_lane_keys("turn_exit", point))
        return keys

    def right_turn_exit(self, ego: LanePoint, scenario_id: str = "") -> LanePoint:
        """``TURN_EXIT_INTO_M`` into the lane the right movement of the junction ahead leads to.

        Follows the ego's lane to the first junction, takes the connecting lane whose movement
        is ``right`` (a signalised one first) and its successor, the exit lane.
        """
        network = self.network
        travelled, approach = 0.0, None
        for segment in network.walk(ego.road_id, ego.lane_id, ego.s):
            approach = junction_approach(network, segment.key)
            travelled += segment.length
            if approach is not None or travelled > TURN_SEARCH_M:
                break
        rights = [] if approach is None else sorted(
            (m for m in approach.movements if m.movement == "right"),
            key=lambda m: m.signal is None)
        exits = network.successors(rights[0].connecting_lane) if rights else []
        if not exits:
            raise NoSpawnFits(f"{scenario_id}: from road {ego.road_id} lane {ego.lane_id} "
                              f"s={ego.s:g} no junction within {TURN_SEARCH_M:.0f} m "
                              "has a right movement with an exit lane")
        exit_lane = exits[0]
        return network.advance(exit_lane.road_id, exit_lane.lane_id,
                               network.entry_s(exit_lane), TURN_EXIT_INTO_M)

    def _route_rejections(self, entry: dict[str, Any], params: Params
                          ) -> tuple[Rejection, ...]:
        """Beyond the database's facts: a lane change must keep its lane ids.

        A lane change names its target relative to the car's lane at its start, and players
        follow lanes by id; where a road ends, the next road may number the same lanes
        differently (Town06's highway: road 52's lane -7 goes on as junction road 415's lane
        -6), and a change under way there ends in the wrong lane. The changing car's lane,
        from where it starts the change (``maneuver_start_s`` at its start speed) over the
        change's length plus a car length, must keep one lane id.
        """
        maneuver = maneuvers.find(params.get("maneuver_class"))
        changer = maneuver.lane_change if maneuver else None
        actor = PREFIX_OF_CHANGER.get(changer) if changer else None
        if actor is None or entry["context"] != "highway":
            return ()
        lane_start, offset = self._changer_lane(entry, actor, params)
        if lane_start is None:
            return ()  # the hard filters' sides judge this
        number = NumberReader(params)
        v0 = number(f"{actor}_speed_ms")
        begin = max(0.0, offset + v0 * number("maneuver_start_s", 0.0))
        end = begin + VEHICLE_MARGIN_M + lane_change_length_m(
            v0, number(f"{actor}_end_speed_ms", v0), number("duration_s", 0.0))
        lanes = list(dict.fromkeys((road, lane) for road, lane, low, high
                                   in self._lane_path(lane_start, end)
                                   if high >= begin and low <= end))
        if len({lane for _, lane in lanes}) <= 1:
            return ()
        path = ", ".join(f"road {road} lane {lane}" for road, lane in lanes)
        return (Rejection("lane_change_lane_ids", f"the {actor}'s lane changes its id during "
                          f"the lane change ({begin:.0f}-{end:.0f} m on: {path})"),)

    def _changer_lane(self, entry: dict[str, Any], actor: str, params: Params
                      ) -> tuple[LanePoint | None, float]:
        """The lane the lane-changing actor starts in, at the spawn's ``s``, and how far along
        it the actor stands at t = 0."""
        geometry = entry["geometry"]
        ego = LanePoint(str(geometry["road_id"]), geometry["lane_id"], geometry["s"])
        if actor == "ego":
            return ego, 0.0
        side, distance = next(((side, distance) for name, side, distance
                               in _placed_actors(params) if name == actor), (None, 0.0))
        if side is None:
            return ego, distance
        neighbour = self.network.neighbour(self.network.key_at(ego.road_id, ego.lane_id, ego.s),
                                           side)
        if neighbour is None:
            return None, 0.0
        return LanePoint(neighbour.road_id, neighbour.lane_id, ego.s), distance

    def _lane_path(self, start: LanePoint, upto_m: float) -> LanePath:
        """``(road, lane, from, to)`` metres of the lane walked from ``start`` (straightest
        on), at least ``upto_m`` far; kept per start, since batches reuse the best spawns."""
        key = (start.road_id, start.lane_id, start.s)
        cached = self._lane_paths.get(key)
        if cached is not None and (cached[0] >= upto_m or cached[1]):
            return cached[2]
        path: LanePath = []
        travelled, ended = 0.0, True
        reach = max(upto_m, LANE_PATH_M)
        for segment in self.network.walk(start.road_id, start.lane_id, start.s):
            path.append((segment.key.road_id, segment.key.lane_id, travelled,
                         travelled + segment.length))
            travelled += segment.length
            if travelled >= reach:
                ended = False
                break
        self._lane_paths[key] = (travelled, ended, path)
        return path

    def _place(self, ego: LanePoint, side: str | None, distance: float,
               params: Params) -> LanePoint:
        if side == ONCOMING:
            return self._place_oncoming(ego, distance, params)
        key = self.network.key_at(ego.road_id, ego.lane_id, ego.s)
        if side is not None:
            neighbour = self.network.neighbour(key, side)
            if neighbour is None:
                raise NoSpawnFits(f"{params.get('scenario_id')}: spawn on road {ego.road_id} "
                                  f"lane {ego.lane_id} has no lane on the {side}")
            key = neighbour
        return self.network.advance(key.road_id, key.lane_id, ego.s, distance)

    def _place_oncoming(self, ego: LanePoint, distance: float,
                        params: Params) -> LanePoint:
        """In the nearest lane of the other direction whose traffic does not turn left across
        the ego's path, ``distance`` ahead along the ego's lane (or, where the road there has
        none, as far ahead as one is, in 5 m steps)."""
        ahead = distance
        while ahead >= 0.0:
            try:
                point = self.network.advance(ego.road_id, ego.lane_id, ego.s, ahead)
            except LaneEndsError:
                point = None
            found = None if point is None else _oncoming_lane_point(self.network, point,
                                                                    distance)
            if found is not None:
                return found
            ahead -= ONCOMING_SEARCH_STEP_M
        raise NoSpawnFits(f"{params.get('scenario_id')}: no lane of the other direction within "
                          f"{distance:.0f} m ahead of the spawn for the recorded oncoming car")


def _oncoming_lane_point(network: Any, point: LanePoint, reach_m: float) -> LanePoint | None:
    """The lane of the other direction at ``point`` nearest the centre line whose traffic does
    not turn left within ``reach_m`` (a recorded oncoming car passes the ego; Town06's inner
    lanes are left-turn lanes that would send it across the ego's path); None if none."""
    for lane in network.oncoming_lanes(network.key_at(point.road_id, point.lane_id, point.s)):
        candidate = LanePoint(point.road_id, lane.lane_id, point.s)
        if not _turns_left(network, candidate, reach_m):
            return candidate
    return None


def _turns_left(network: Any, start: LanePoint, reach_m: float) -> bool:
    """Whether the walk from ``start`` (straightest on, as players drive) turns left at a
    junction within ``reach_m``."""
    travelled, approach = 0.0, None
    for segment in network.walk(start.road_id, start.lane_id, start.s):
        place = (segment.key.road_id, segment.key.lane_id)
        if approach is not None and any(
                m.movement == "left" and (m.connecting_lane.road_id,
                                          m.connecting_lane.lane_id) == place
                for m in approach.movements):
            return True
        approach = junction_approach(network, segment.key)
        travelled += segment.length
        if travelled > reach_m:
            return False
    return False


def _hard_filters(entry: dict[str, Any], needs: Requirements) -> Iterator[Rejection]:
    features, drivable = entry["features"], entry["drivable"]
    if entry["context"] != needs.domain:
        yield Rejection("context", f"spawn is {entry['context']}, scenario is {needs.domain}")
        return
    if features["is_junction"]:
        yield Rejection("junction", "spawn is on a junction")
    if needs.domain == "highway":
        if features["is_intersection"] or features["is_intersection_w_traffic_light"]:
            yield Rejection("intersection", "an intersection or traffic light is within reach")
        signal = drivable["signal_ahead_m"]
        if signal is not None and signal < needs.light_free_m:
            yield Rejection("traffic_light_on_route",
                            f"a signalised junction {signal:.0f} m ahead, inside the "
                            f"{needs.light_free_m:.0f} m that must be free of lights")
    else:
        yield from _urban_filters(entry, needs)
    for side in needs.sides:
        lane = entry["lanes"][side]
        if lane["count"] == 0:
            yield Rejection(f"{side}_lane", f"no same-direction lane on the {side}")
        elif lane["ahead_m"] < needs.side_ahead_m or lane["behind_m"] < needs.side_behind_m:
            yield Rejection(f"{side}_lane",
                            f"the {side} lane runs {lane['behind_m']:.0f} m back and "
                            f"{lane['ahead_m']:.0f} m on, {needs.side_behind_m:.0f} m and "
                            f"{needs.side_ahead_m:.0f} m needed")
    if drivable["ahead_m"] < needs.ahead_m:
        yield Rejection("length_ahead", f"{drivable['ahead_m']:.0f} m drivable ahead, "
                                        f"{needs.ahead_m:.0f} m needed")
    if drivable["behind_m"] < needs.behind_m:
        yield Rejection("length_behind", f"{drivable['behind_m']:.0f} m drivable behind, "
                                         f"{needs.behind_m:.0f} m needed")


def _urban_filters(entry: dict[str, Any], needs: Requirements) -> Iterator[Rejection]:
    movement = needs.light_movement
    if movement is not None and not entry["surroundings"]["traffic_lights"]:
        yield Rejection("traffic_light", "no traffic light ahead of the spawn")
    elif movement is not None and _light_for(entry, movement) is None:
        yield Rejection("traffic_light", f"no light controls the {movement} movement")
    stop_line, within = entry["surroundings"]["stop_line_distance_m"], needs.stop_line_within_m
    if within is not None and stop_line is not None and stop_line > within:
        yield Rejection("stop_line_reach", f"the stop line is {stop_line:.1f} m ahead, the "
                        f"recorded drive reaches {within:.1f} m (less the ego's front): the "
                        "ego would never cross it")
    maneuver = maneuvers.by_tag(needs.tag)
    if maneuver is None or not suits_urban(entry, maneuver):  # asked now: plugins spawn too
        yield Rejection("suitable_for", f"{needs.tag!r} does not suit it (a light class needs "
                                        "a light over its movement, others road ahead)")


def _score(entry: dict[str, Any], needs: Requirements) -> float:
    """Table 5.3: the spawn's own points plus those its fit to the scenario earns."""
    return _fixed_score(entry) + _needs_score(entry, needs)


def _fixed_score(entry: dict[str, Any]) -> float:
    """The Table 5.3 points a spawn earns whatever the scenario."""
    priority: float = 10.0 * entry["annotations"]["priority"]
    if entry["context"] == "highway":
        points: float = (30.0 + 15.0 * entry["features"]["is_straight"]
                         + 10.0 * entry["surroundings"]["is_highway_layout"]
                         + 15.0 * (entry["drivable"]["ahead_m"] > 100.0) + priority)
        return points
    reviewed: bool = entry["annotations"]["manually_reviewed"]
    return 30.0 + priority + 10.0 * reviewed


def _needs_score(entry: dict[str, Any], needs: Requirements) -> float:
    """The Table 5.3 points that depend on the scenario (at most ``NEEDS_POINTS_MAX``)."""
    limit: float = entry["surroundings"]["speed_limit_kmh"]
    if needs.domain == "highway":
        return max(0.0, 20.0 - 0.5 * abs(limit - needs.speed_kmh))
    score = 0.0
    if needs.speed_limit_kmh is not None:
        score += max(0.0, 20.0 - abs(limit - needs.speed_limit_kmh))
    stop_line: float | None = entry["surroundings"]["stop_line_distance_m"]
    if needs.light_movement is None:
        # no light in the manoeuvre: the light-distance points go to room to drive it before
        # the next light instead
        room = stop_line is None or stop_line >= (needs.drive_distance_m or 0.0) + VEHICLE_MARGIN_M
        return score + 30.0 * room
    light = _light_for(entry, needs.light_movement)
    if light is not None:
        if needs.tfl_ds_m is not None:
            score += max(0.0, 30.0 - abs(light["distance_m"] - needs.tfl_ds_m))
        if stop_line is not None:
            score += 15.0
    return score


def _light_for(entry: dict[str, Any], movement: str) -> dict[str, Any] | None:
    """The light controlling ``movement`` out of the spawn's lane, nearest first."""
    lights: list[dict[str, Any]] = entry["surroundings"]["traffic_lights"]
    for light in lights:
        if movement in light.get("movements", []):
            return light
    return None


def _spread_over_roads(candidates: list[SpawnCandidate]) -> list[SpawnCandidate]:
    """Best score first; among equal scores, alternate roads so the top N is spread out."""
    ordered = sorted(candidates, key=lambda c: (-c.score, c.spawn_id))
    seen: Counter[tuple[float, str]] = Counter()
    rank: dict[int, int] = {}
    for candidate in ordered:
        group = (candidate.score, candidate.entry["geometry"]["road_id"])
        rank[candidate.spawn_id] = seen[group]
        seen[group] += 1
    return sorted(ordered, key=lambda c: (-c.score, rank[c.spawn_id], c.spawn_id))


#: the "side" of an actor placed in the nearest lane of the other direction
ONCOMING = "oncoming"
#: where the road ahead has no lane of the other direction, look this much nearer (m)
ONCOMING_SEARCH_STEP_M = 5.0


def _placed_actors(params: Params) -> list[tuple[str, str | None, float]]:
    """``(actor, adjacent side or None, signed distance along the lane at t = 0)`` of every
    NPC: a highway NPC where its recorded gap holds at ``maneuver_start_s``, the urban lead
    ``lead_distance_m`` ahead along the ego's lane (on its lane, facing its traffic), the
    oncoming car ``oncoming_distance_m`` ahead in the nearest lane of the other direction."""
    if params.get("domain") == "urban":
        number = NumberReader(params)
        placed: list[tuple[str, str | None, float]] = []
        if params.get("lead_present"):
            placed.append(("lead", None, number("lead_distance_m", 0.0)))
        if params.get("oncoming_present"):
            placed.append(("oncoming", ONCOMING, number("oncoming_distance_m", 0.0)))
        return placed
    if params.get("domain") != "highway":
        return []
    placed = []
    maneuver = maneuvers.find(params.get("maneuver_class"))
    by_slot = maneuver is not None and maneuver.surrounding_slots
    if params.get("has_npc") and not by_slot:
        side: str | None = None
        if maneuver is not None and maneuver.npc_starts_beside:
            sides = params.get("required_lane_sides") or []
            side = sides[0] if sides else None
        placed.append(("npc", side, _start_distance(params, "npc")))
    for slot, side in FREE_RIDE_SLOTS.items():
        if actor_value(params, slot, "present"):
            placed.append((slot, side, _start_distance(params, slot)))
    return placed


def _start_distance(params: Params, actor: str) -> float:
    """Where ``actor`` stands at t = 0, ahead of the ego (m): its recorded gap minus the
    lead-in drift (``scenario_lib.kinematics.start_gap_m``)."""
    number = NumberReader(params)
    return start_gap_m(number(f"{actor}_distance_m", 0.0), number(f"{actor}_speed_ms"),
                       number("ego_speed_ms"), number("maneuver_start_s", 0.0))


def _pose_keys(actor: str, x: float, y: float, z: float, h: float) -> dict[str, float]:
    return {f"{actor}_x": round(x, 4), f"{actor}_y": round(y, 4), f"{actor}_z": round(z, 4),
            f"{actor}_h": round(math.remainder(h, 2 * math.pi), 6)}


def _lane_keys(actor: str, point: LanePoint) -> dict[str, Any]:
    road_id = int(point.road_id) if point.road_id.lstrip("-").isdigit() else point.road_id
    return {f"{actor}_road_id": road_id, f"{actor}_lane_id": point.lane_id,
            f"{actor}_s": round(point.s, 4)}


def _light_keys(entry: dict[str, Any], needs: Requirements) -> dict[str, Any]:
    light = _light_for(entry, needs.light_movement or "straight")
    if light is None:
        light = (entry["surroundings"]["traffic_lights"] or [None])[0]
    return {
        "tfl_x_carla": light["x"] if light else None,
        "tfl_y_carla": light["y"] if light else None,
        "spawn_tfl_distance_m": light["distance_m"] if light else None,
        "spawn_stop_line_distance_m": entry["surroundings"]["stop_line_distance_m"],
    }


def _no_fit_message(params: Params, map_name: str,
                    assessments: list[Assessment]) -> str:
    scenario = params.get("scenario_id", "<no scenario_id>")
    in_context = [a for a in assessments
                  if not any(r.constraint == "context" for r in a.rejections)]
    if not in_context:
        return (f"{scenario} ({params.get('maneuver_class')}): map {map_name} has no "
                f"{params.get('domain')} lane that fits (no {params.get('domain')} spawn point "
                "in its spawn database)")
    counts = Counter(r.constraint for a in in_context for r in a.rejections)
    constraint, count = counts.most_common(1)[0]
    example = next(r for a in in_context for r in a.rejections if r.constraint == constraint)
    return (f"{scenario} ({params.get('maneuver_class')}): no spawn point on map {map_name} "
            f"fits; {constraint} rules out {count} of {len(in_context)} "
            f"{params.get('domain')} spawn points (e.g. {example.detail})")


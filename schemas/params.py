"""The params contract (``docs/params.md``) as one typed model, its JSON Schema, and one reader.

:class:`Params` names every key a stage may read and its type; ``schemas/params.schema.json``
is generated from it (``python -m scenweave.schemas.params`` rewrites it, a test checks the two
agree). :func:`check_params` validates a params dict once, where it is made (extraction,
variants, the spawn stage); readers then use :func:`number` for optional numbers instead of
each re-checking types their own way.
"""

from __future__ import annotations

import json
import math
import sys
import types
import typing
from collections.abc import Callable, Mapping
from functools import cache
from pathlib import Path
from typing import Any, Literal, TypeGuard, cast, overload

import fastjsonschema
import typing_extensions
from typing_extensions import ReadOnly, TypedDict

from scenweave.errors import InputError, ParamsError
from scenweave.maneuvers.free_ride import SLOTS
from scenweave.scenario_lib.phases import PhaseRecord

SCHEMA_PATH = Path(__file__).with_name("params.schema.json")

VehicleType = Literal["car", "truck", "van", "motorcycle"]
Side = Literal["left", "right"]
#: the actors the spawn stage places, each with a world pose and a lane position at t = 0
PLACED_ACTORS = ("ego", "npc", "center", "right", "left", "lead", "oncoming", "turn_exit",
                 "background")


class Params(TypedDict, total=False):
    """One scenario's params: what ingest extracted, the spawn stage filled in and every later
    stage reads. Units are SI unless the key says otherwise. ``docs/params.md`` explains each
    key; the slot (``center_*``...) and spawn (``ego_x``...) families are added below."""

    # -- every params dict -----------------------------------------------------------------
    scenario_id: ReadOnly[str]
    maneuver_class: ReadOnly[str]
    maneuver_tag: ReadOnly[str]
    domain: ReadOnly[Literal["highway", "urban"]]
    weather_key: ReadOnly[str]
    duration_s: ReadOnly[float]
    maneuver_start_s: ReadOnly[float]
    timeout_s: ReadOnly[float]
    ego_speed_ms: ReadOnly[float]
    ego_end_speed_ms: ReadOnly[float]
    has_npc: ReadOnly[bool]
    npc_position: ReadOnly[Literal["front", "behind"] | None]
    required_lane_sides: ReadOnly[list[Side]]
    max_speed_ms: ReadOnly[float]
    gap_ahead_m: ReadOnly[float]
    gap_behind_m: ReadOnly[float]
    spawn_id: ReadOnly[int | None]
    description: ReadOnly[str]
    #: the map the scenario is made for: a bundled CARLA town's name or an .xodr path
    map: ReadOnly[str]

    # -- highway ---------------------------------------------------------------------------
    npc_speed_ms: ReadOnly[float]
    npc_end_speed_ms: ReadOnly[float]
    delta_speed_ms: ReadOnly[float]
    npc_distance_m: ReadOnly[float]
    npc_distance_end_m: ReadOnly[float]
    npc_dist_traveled_m: ReadOnly[float]
    npc_vehicle_type: ReadOnly[VehicleType]
    brake_intensity: ReadOnly[float]
    other_dir_traffic: ReadOnly[bool]
    lane_change_direction: ReadOnly[Side]
    #: a mined lane change as its lateral position recorded it (docs/params.md): when the
    #: changer crossed the line (s after maneuver_start_s) and how far apart the two lanes'
    #: centres lie (m); where it starts across its lane is ``<actor>_lane_offset_m``
    lane_change_cross_s: ReadOnly[float]
    lane_change_width_m: ReadOnly[float]
    behavior_type: ReadOnly[Literal["B1", "B2", "B3", "B4"]]
    ego_dist_traveled_m: ReadOnly[float]
    driving_side: ReadOnly[Side]
    #: an actor's speed as phases where one ramp does not show the record (scenario_lib.phases)
    ego_phases: ReadOnly[list[PhaseRecord]]
    npc_phases: ReadOnly[list[PhaseRecord]]
    #: what a mined record recorded at every sample (t from the manoeuvre start; speeds,
    #: gaps...): the replay is compared with it (judge.replay)
    recorded_series: ReadOnly[dict[str, list[float | None]]]

    # -- urban -----------------------------------------------------------------------------
    road_type: ReadOnly[str]
    init_speed_ms: ReadOnly[float]
    final_speed_ms: ReadOnly[float]
    brake_time_s: ReadOnly[float]
    yellow_delay_s: ReadOnly[float | None]
    drive_distance_m: ReadOnly[float]
    tfl_ds_m: ReadOnly[float | None]
    tfl_state: ReadOnly[Literal["green", "orange", "red"] | None]
    turn: ReadOnly[Literal["straight", "right"]]
    #: what the record says of its road, when it says it: no stage needs these
    speed_limit_kmh: ReadOnly[float | None]
    lane_count: ReadOnly[int | None]
    lane_width_m: ReadOnly[float | None]
    lead_present: ReadOnly[bool]
    lead_distance_m: ReadOnly[float]
    lead_speed_ms: ReadOnly[float]
    lead_vehicle_type: ReadOnly[VehicleType | None]
    oncoming_present: ReadOnly[bool]
    oncoming_distance_m: ReadOnly[float]
    oncoming_speed_ms: ReadOnly[float]
    oncoming_vehicle_type: ReadOnly[VehicleType | None]
    pedestrian_present: ReadOnly[bool]
    min_ttc_s: ReadOnly[float | None]
    v_noise_std: ReadOnly[float]
    dl_noise_std: ReadOnly[float]
    t_noise_std: ReadOnly[float]
    tfl_x_carla: ReadOnly[float | None]
    tfl_y_carla: ReadOnly[float | None]
    spawn_tfl_distance_m: ReadOnly[float | None]
    spawn_stop_line_distance_m: ReadOnly[float | None]
    # -- background traffic (a ``--vary`` traffic variant; SpawnMatcher.background) --------
    background_present: ReadOnly[bool]
    background_speed_ms: ReadOnly[float]
    background_vehicle_type: ReadOnly[VehicleType | None]


#: every params dict has these (spawn keys null until the spawn stage fills them)
REQUIRED = ("scenario_id", "maneuver_class", "maneuver_tag", "domain", "weather_key",
            "duration_s", "maneuver_start_s", "timeout_s", "ego_speed_ms", "ego_end_speed_ms",
            "has_npc", "npc_position", "required_lane_sides", "max_speed_ms", "gap_ahead_m",
            "gap_behind_m", "spawn_id")
#: ``<slot>_<key>`` of each free-ride slot
SLOT_KEYS: dict[str, Any] = {
    "present": bool, "speed_ms": float, "end_speed_ms": float, "distance_m": float,
    "end_distance_m": float, "vehicle_type": VehicleType | None,
    "phases": list[PhaseRecord]}
#: ``<actor>_<key>`` of each placed actor: world pose (OpenSCENARIO frame) and lane position
POSE_KEYS: dict[str, Any] = {
    "x": float | None, "y": float | None, "z": float | None, "h": float | None,
    "road_id": int | None, "lane_id": int | None, "s": float | None,
    "in_junction": bool | None, "lane_offset_m": float | None}


class ParamsInvalid(InputError, ValueError):
    """Params that break the contract: the message names the key."""

    def __init__(self, message: str, key: str | None = None) -> None:
        super().__init__(message)
        self.key = key


def all_keys() -> dict[str, Any]:
    """Every key of the contract and its type."""
    keys = dict(typing_extensions.get_type_hints(Params))
    keys |= {f"{slot}_{key}": kind for slot in SLOTS for key, kind in SLOT_KEYS.items()}
    keys |= {f"{actor}_{key}": kind for actor in PLACED_ACTORS for key, kind in POSE_KEYS.items()}
    return keys


def json_schema() -> dict[str, Any]:
    """The JSON Schema of the contract (what ``schemas/params.schema.json`` holds)."""
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://scenweave.local/schemas/params.schema.json",
        "title": "ScenWeave params",
        "description": "The params dict every stage shares (docs/params.md). Generated from "
                       "scenweave.schemas.params.Params; do not edit by hand.",
        "type": "object",
        "required": list(REQUIRED),
        "properties": {key: _json_type(kind) for key, kind in sorted(all_keys().items())},
    }


def _json_type(kind: Any) -> dict[str, Any]:
    if kind is bool:
        return {"type": "boolean"}
    if kind is int:
        return {"type": "integer"}
    if kind is float:
        return {"type": "number"}
    if kind is str:
        return {"type": "string"}
    if typing.is_typeddict(kind):
        hints = typing.get_type_hints(kind)
        return {"type": "object", "required": sorted(kind.__required_keys__),
                "properties": {key: _json_type(hint) for key, hint in hints.items()},
                "additionalProperties": False}
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin is dict:
        return {"type": "object", "additionalProperties": _json_type(args[1])}
    if origin is Literal:
        return {"enum": list(args)}
    if origin is list:
        return {"type": "array", "items": _json_type(args[0])}
    if origin in (typing.Union, types.UnionType):
        options = [_json_type(arg) for arg in args if arg is not type(None)]
        nullable = type(None) in args
        if len(options) == 1 and "enum" in options[0]:
            return {"enum": [*options[0]["enum"], *([None] if nullable else [])]}
        if len(options) == 1 and nullable:
            return {"type": [options[0]["type"], "null"]}
        return {"anyOf": [*options, *([{"type": "null"}] if nullable else [])]}
    raise TypeError(f"no JSON Schema type for {kind!r}")


@cache
def _validator() -> Callable[[dict[str, Any]], Any]:
    return fastjsonschema.compile(json.loads(SCHEMA_PATH.read_text(encoding="utf-8")))


def check_params(params: Mapping[str, Any]) -> None:
    """Raise :class:`ParamsInvalid` naming the key when ``params`` break the contract
    (a missing key, a wrong type, a value outside its set, a NaN or infinite number)."""
    try:
        _validator()(dict(params))
    except fastjsonschema.JsonSchemaValueException as err:
        key = (err.name or "").removeprefix("data.").removeprefix("data") or None
        raise ParamsInvalid(f"params break docs/params.md: {err.message}", key) from err
    for key, value in params.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise ParamsInvalid(f"params key {key!r} is {value}, not a finite number", key)


def checked(params: Mapping[str, Any]) -> Params:
    """``params`` typed as the contract, once :func:`check_params` found it keeps it (raises
    :class:`ParamsInvalid` otherwise): where a stage's dict becomes ``Params``."""
    check_params(params)
    return cast(Params, params)


def unchecked(params: Mapping[str, Any]) -> Params:
    """``params`` read back from a scenario folder's params.json, typed as the contract
    without the check: its readers (the judge, the viewer, the replay figure) take what they
    find (:func:`finite`, :func:`actor_value` give None for a missing or broken value), so a
    hand-edited file is judged, not refused. Where a stage makes params, :func:`checked`."""
    return cast(Params, params)


def number(params: Mapping[str, Any], key: str) -> float | None:
    """``params[key]`` as a float, or None when it is absent, null (not yet filled) or not a
    finite number: for judging what a scenario did, where a missing value means "not checked".
    For a dict of unknown shape (a params.json read back); a ``Params`` reader writes
    ``finite(params.get("ego_speed_ms"))``, whose key mypy checks."""
    return finite(params.get(key))


def finite(value: float | None) -> float | None:
    """``value`` as a float, None when it is None or not a finite number (a hand-made params
    file may hold anything). Typed ``float | None`` so that what it reads is a number key of
    :class:`Params`: ``params.get("ego_sped_ms")`` is ``object`` to mypy, and an error here."""
    return float(value) if _is_finite_number(value) else None


def all_finite(*values: float | None) -> tuple[float, ...] | None:
    """Each of ``values`` by :func:`finite`, in order; None when any is missing: the numbers a
    rule needs together (``all_finite(params.get("ego_speed_ms"), params.get("duration_s"))``)."""
    found = tuple(finite(value) for value in values)
    return None if None in found else cast(tuple[float, ...], found)


#: the suffixes of the ``<actor>_<key>`` families, by the type of their values
FlagKey = Literal["present", "in_junction"]
LaneKey = Literal["road_id", "lane_id"]
NumberKey = Literal["speed_ms", "end_speed_ms", "distance_m", "end_distance_m",
                    "x", "y", "z", "h", "s", "lane_offset_m"]
#: the suffix of a key of an actor's family: ``SLOT_KEYS`` and ``POSE_KEYS`` (a test pins it)
ActorKey = FlagKey | LaneKey | NumberKey | Literal["vehicle_type", "phases"]


@overload
def actor_value(params: Params, actor: str, key: FlagKey) -> bool | None: ...
@overload
def actor_value(params: Params, actor: str, key: LaneKey) -> int | None: ...
@overload
def actor_value(params: Params, actor: str, key: NumberKey) -> float | None: ...
@overload
def actor_value(params: Params, actor: str,
                key: Literal["vehicle_type"]) -> VehicleType | None: ...
@overload
def actor_value(params: Params, actor: str,
                key: Literal["phases"]) -> list[PhaseRecord] | None: ...
def actor_value(params: Params, actor: str, key: ActorKey) -> object:
    """``params["<actor>_<key>"]`` (None when absent): a key of the per-actor and per-slot
    families (``npc_speed_ms``, ``center_present``, ``ego_road_id``...), which :class:`Params`
    cannot name one by one since the actor is a variable. The suffix is checked by mypy and
    the value typed by it: ``actor_value(params, prefix, "sped_ms")`` is an error."""
    values: Mapping[str, object] = params
    return values.get(f"{actor}_{key}")


class NumberReader:
    """Reads numbers a stage needs from one params dict: ``reader(key)``, ``reader(key,
    default)`` and ``reader.optional(key)`` give floats, and a missing (or null) needed key or a
    value that is not a finite number raises :class:`errors.ParamsError` naming the scenario and
    the key. Stages are public APIs too: hand-made params get one clear error."""

    def __init__(self, params: Mapping[str, Any]) -> None:
        self.params = params
        self.scenario_id = str(params.get("scenario_id", "<no scenario_id>"))

    def __call__(self, key: str, default: float | None = None) -> float:
        value = self.params.get(key, default)
        if value is None:
            raise ParamsError(f"{self.scenario_id}: params lack {key!r} (docs/params.md)")
        return self._finite(key, value)

    def optional(self, key: str) -> float | None:
        """``params[key]``, None when absent or null."""
        value = self.params.get(key)
        return None if value is None else self._finite(key, value)

    def _finite(self, key: str, value: Any) -> float:
        if not _is_finite_number(value):
            raise ParamsError(f"{self.scenario_id}: {key}={value!r} is not a finite number")
        return float(value)


def _is_finite_number(value: object) -> TypeGuard[int | float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def write_schema() -> None:
    """Regenerate ``schemas/params.schema.json`` from :class:`Params`."""
    SCHEMA_PATH.write_text(json.dumps(json_schema(), indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    write_schema()
    sys.stdout.write(f"wrote {SCHEMA_PATH}\n")

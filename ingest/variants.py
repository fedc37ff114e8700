"""Variants of a record, in one place: perturbed copies of its params (thesis §5.1,
``extract_with_variants``), and what a variant of a delivered scenario (``scenweave run
--vary N``) is asked to play: :func:`vary`, which the pipeline calls before the agent writes
the variant, so the agent gets the params it is to play and places nothing itself.

The weather is the LLM's to choose: its variant is asked the record as it is. A vehicle model,
background traffic and the lane touch values the record's other values depend on, or must keep
clear of it, so what the record becomes is worked out here:

- another model for one vehicle keeps the free space between the bumpers the record fixes
  (:func:`with_vehicle_type`), so the reference-point gaps move, and the scenario is placed
  anew from the same spawn point (``SpawnMatcher.named_spawn``);
- background traffic: one vehicle in a same-direction lane the record neither starts in nor
  moves into, ``BACKGROUND_AHEAD_M`` ahead of the ego at its speed
  (``SpawnMatcher.lane_free_of_record``; the reference scripts play it through
  ``scenario_lib.builder.make_scenario``);
- the lane: the record placed one lane over (``SpawnMatcher.spawns_beside``), its gaps
  measured along the new lanes.

Where the record has no room one lane over (``VARY_NO_LANE``), no vehicle but the ego
(``VARY_NO_VEHICLE``), or no room for the other model or a free lane (``VARY_NO_ROOM``),
:class:`NotAsked` says so and no LLM call is spent.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from scenweave import maneuvers
from scenweave.errors import ScenarioError
from scenweave.ingest.extract import extract_params, finish, gap_keys
from scenweave.ingest.urban import DEFAULT_PERTURBATION
from scenweave.scenario_lib.vehicles import bumper_gap_m, known_type, reference_gap_m
from scenweave.schemas.params import Params, actor_value, checked
from scenweave.spawn_db import SpawnDbError, SpawnMatcher
from scenweave.spawn_db.registry import Matcher

DERIVED_ONLY_FOR = {  # keys ``finish`` recomputes from the perturbed ones
    "init_speed_ms": lambda p: True,
    "final_speed_ms": lambda p: True,
    "npc_end_speed_ms": lambda p: "delta_speed_ms" in p,
    "ego_end_speed_ms": lambda p: maneuvers.get(p["maneuver_class"]).ego_end_speed_factor
    is not None,
}
TIME_KEYS = ("duration_s", "brake_time_s", "yellow_delay_s")
MIN_DURATION_S = 0.1


def extract_with_variants(record: dict, n: int, seed: int) -> list[Params]:
    """``n`` params dicts drawn around the record's: Gaussian noise on speeds and timings.

    Noise scales come from the record's perturbation block (urban) or the defaults (highway).
    A standstill stays a standstill; ids end in ``_v01``, ``_v02``...; same seed, same copies.
    """
    base = extract_params(record)
    noise = {**DEFAULT_PERTURBATION, **record.get("perturbation", {})}
    rng = np.random.default_rng([seed, zlib.crc32(base["scenario_id"].encode())])
    return [_variant(base, index, rng, noise) for index in range(1, n + 1)]


def _variant(base: Mapping[str, Any], index: int, rng: np.random.Generator,
             noise: dict) -> Params:
    params = dict(base)
    params["scenario_id"] = f"{base['scenario_id']}_v{index:02d}"
    for key in _perturbed_speed_keys(base):
        params[key] = max(base[key] + float(rng.normal(0, noise["v_noise_std"])), 0.0)
    for key in TIME_KEYS:
        if isinstance(base.get(key), float):
            params[key] = max(base[key] + float(rng.normal(0, noise["t_noise_std"])),
                              MIN_DURATION_S)
    if params.get("yellow_delay_s") is not None:
        params["yellow_delay_s"] = min(max(params["yellow_delay_s"], 1.0), 8.0)
    if params.get("brake_time_s") is not None:
        params["brake_time_s"] = min(params["brake_time_s"], params["duration_s"])
    return finish(params)


def _perturbed_speed_keys(params: Mapping[str, Any]) -> list[str]:
    keys = []
    for key, value in params.items():
        if not key.endswith("speed_ms") or not isinstance(value, float) or value <= 0:
            continue
        if key == "max_speed_ms" or DERIVED_ONLY_FOR.get(key, lambda p: False)(params):
            continue
        keys.append(key)
    return keys


# -- what a --vary variant is asked to play ------------------------------------------------------

#: the vehicle models a vehicles variant gives a recorded actor, in turn
VEHICLE_TYPES = ("car", "van", "truck")
#: a background vehicle starts this far ahead of the ego (m)
BACKGROUND_AHEAD_M = 15.0
#: the models background vehicles take, in turn
BACKGROUND_MODELS = ("car", "van", "truck")
#: the code of an aspect the spawn stage finds no room for
NO_ROOM = {"lane": "VARY_NO_LANE", "traffic": "VARY_NO_ROOM", "vehicles": "VARY_NO_ROOM"}


class NotAsked(ScenarioError):
    """A variant of this aspect cannot be made of the record; ``code`` says why."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code = code


def vary(params: Params, aspect: str, round_number: int, matcher: Matcher) -> Params:
    """The record (``params``, placed by ``matcher``) as a variant of ``aspect`` must play it
    (``round_number``: how many of this aspect were asked before): as it is for the weather,
    which the LLM chooses; with one vehicle another model, with a background vehicle in a lane
    the record leaves free, or one lane over. Raises :class:`NotAsked`."""
    if aspect not in NO_ROOM:
        return params
    placing = _placing(matcher, aspect)
    try:
        if aspect == "lane":
            beside = placing.spawns_beside(params)
            return placing.place(params, beside[round_number % len(beside)])
        if aspect == "traffic":
            return _with_background(placing, params, round_number)
        return _with_other_model(placing, params, round_number)
    except SpawnDbError as err:
        raise NotAsked(NO_ROOM[aspect], str(err)) from err


def _placing(matcher: Matcher, aspect: str) -> SpawnMatcher:
    """The spawn database's matcher, which places variants; another matcher (a plugin's)
    places the record only."""
    if not isinstance(matcher, SpawnMatcher):
        raise NotAsked(NO_ROOM[aspect], f"the spawn matcher {type(matcher).__name__} places "
                       f"no {aspect} variants (a SpawnMatcher does)")
    return matcher


def _with_background(matcher: SpawnMatcher, placed: Params, index: int) -> Params:
    """``placed`` with one background vehicle (the ``background_*`` keys) in the free lane
    ``index`` picks, at the ego's start speed, in turn a ``BACKGROUND_MODELS`` model."""
    point = matcher.lane_free_of_record(placed, BACKGROUND_AHEAD_M, index)
    return checked({**placed, "background_present": True,
                    "background_speed_ms": float(placed["ego_speed_ms"]),
                    "background_vehicle_type": BACKGROUND_MODELS[index % len(BACKGROUND_MODELS)],
                    **matcher.actor_keys("background", point)})


def _with_other_model(matcher: SpawnMatcher, params: Params, round_number: int) -> Params:
    """One recorded vehicle (in turn) another model (in turn), placed anew from its spawn."""
    actors = vehicle_actors(params)
    if not actors:
        raise NotAsked("VARY_NO_VEHICLE", "the record has no vehicle but the ego")
    actor = actors[round_number % len(actors)]
    others = [t for t in VEHICLE_TYPES
              if t != known_type(actor_value(params, actor, "vehicle_type"))]
    changed = with_vehicle_type(params, actor, others[(round_number // len(actors))
                                                      % len(others)])
    return matcher.place(changed, matcher.named_spawn(changed))


def vehicle_actors(params: Params) -> list[str]:
    """The params prefixes of the recorded actors besides the ego (each has a model)."""
    actors = []
    for key in params:
        actor = key.removesuffix("_vehicle_type")
        present = params.get("has_npc") if actor == "npc" else actor_value(params, actor,
                                                                           "present")
        if key.endswith("_vehicle_type") and present:
            actors.append(actor)
    return actors


def with_vehicle_type(params: Mapping[str, Any], prefix: str, vehicle_type: str) -> Params:
    """``params`` with actor ``prefix`` (``npc``, a free-ride slot, ``lead``, ...) driving
    another model: the free space between the facing bumpers, which the record fixes, is
    kept, so the reference-point gaps params hold move by the change in length; the values
    that follow are derived anew (``finish``). The spawn keys are the caller's to redo."""
    changed = {**params, f"{prefix}_vehicle_type": vehicle_type}
    before = params.get(f"{prefix}_vehicle_type")
    for key in gap_keys(prefix):
        value = params.get(key)
        bumpers = (bumper_gap_m(value, before)
                   if isinstance(value, float | int) and not isinstance(value, bool) else None)
        if bumpers is not None:
            changed[key] = reference_gap_m(bumpers, vehicle_type)
    return finish(changed)

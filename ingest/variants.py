"""Perturbed copies of a scenario (thesis §5.1 ``extract_with_variants``)."""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from scenweave import maneuvers
from scenweave.ingest.extract import extract_params, finish
from scenweave.ingest.urban import DEFAULT_PERTURBATION
from scenweave.schemas.params import Params

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

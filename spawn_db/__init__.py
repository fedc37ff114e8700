"""Spawn points: a spawn database per map and the SpawnMatcher (maps and lanes: ``roads``).

Public API:
- ``spawn_database(map_ref, cache_dir)`` -> the map's database file (shipped for Town04,
  else built on first use and cached under the map file's sha256), ``database_path``.
- ``SpawnMatcher(db_path=DEFAULT_DB_PATH)`` or ``SpawnMatcher.for_map(map_ref, cache_dir)``,
  with ``.find(params, top_n)`` (ranked ``SpawnCandidate`` list), ``.assess(params)``
  (every spawn's score or rejections) and
  ``.assign(params, index, top_n=5)`` (a new params dict with the spawn keys and ``map``
  filled); for variants (``ingest.variants``) ``.spawns_beside``, ``.lane_free_of_record``,
  ``.named_spawn``, ``.place`` and ``.actor_keys``.
- ``registry``: the ``Matcher`` protocol the pipeline calls and the named matchers of
  ``--matcher`` (``matcher_names``, ``matcher_factory``, ``matcher_for``).
- ``build_database(map_path)``, ``write_database``, ``load_database``, ``mark_reviewed``,
  ``carry_reviews``.
- Errors: ``SpawnDbError`` (root), ``NoSpawnFits``, ``SpawnDatabaseError``; params it cannot
  place raise ``errors.ParamsError``.

The database and matcher names load on first use (the map, its lanes and NumPy come with
them), so the registry and the errors import without them: ``scenweave submit`` names a
matcher without loading one.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from scenweave.errors import ParamsError
from scenweave.spawn_db.errors import NoSpawnFits, SpawnDatabaseError, SpawnDbError

if TYPE_CHECKING:
    from scenweave.spawn_db.database import (
        DEFAULT_DB_PATH,
        build_database,
        carry_reviews,
        database_path,
        load_database,
        mark_reviewed,
        spawn_database,
        write_database,
    )
    from scenweave.spawn_db.matcher import (
        Assessment,
        Rejection,
        SpawnCandidate,
        SpawnMatcher,
    )

_LAZY = {
    **dict.fromkeys(("DEFAULT_DB_PATH", "build_database", "carry_reviews", "database_path",
                     "load_database", "mark_reviewed", "spawn_database", "write_database"),
                    "scenweave.spawn_db.database"),
    **dict.fromkeys(("Assessment", "Rejection", "SpawnCandidate", "SpawnMatcher"),
                    "scenweave.spawn_db.matcher"),
}

__all__ = [
    "DEFAULT_DB_PATH", "Assessment", "NoSpawnFits", "ParamsError", "Rejection",
    "SpawnCandidate", "SpawnDatabaseError", "SpawnDbError", "SpawnMatcher", "build_database",
    "carry_reviews", "database_path", "load_database", "mark_reviewed", "spawn_database",
    "write_database",
]


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'scenweave.spawn_db' has no attribute {name!r}")
    return getattr(importlib.import_module(_LAZY[name]), name)

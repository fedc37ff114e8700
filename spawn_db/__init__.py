"""Spawn points: a spawn database per map and the SpawnMatcher (maps and lanes: ``roads``).

Public API:
- ``spawn_database(map_ref, cache_dir)`` -> the map's database file (shipped for Town04,
  else built on first use and cached under the map file's sha256), ``database_path``.
- ``SpawnMatcher(db_path=DEFAULT_DB_PATH)`` or ``SpawnMatcher.for_map(map_ref, cache_dir)``,
  with ``.find(params, top_n)`` (ranked ``SpawnCandidate`` list), ``.assess(params)``
  (every spawn's score or rejections) and
  ``.assign(params, index, top_n=5)`` (a new params dict with the spawn keys and ``map``
  filled).
- ``build_database(map_path)``, ``write_database``, ``load_database``, ``mark_reviewed``,
  ``carry_reviews``.
- Errors: ``SpawnDbError`` (root), ``NoSpawnFits``, ``SpawnDatabaseError``; params it cannot
  place raise ``errors.ParamsError``.
"""

from __future__ import annotations

from scenweave.errors import ParamsError
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
from scenweave.spawn_db.errors import NoSpawnFits, SpawnDatabaseError, SpawnDbError
from scenweave.spawn_db.matcher import Assessment, Rejection, SpawnCandidate, SpawnMatcher

__all__ = [
    "DEFAULT_DB_PATH", "Assessment", "NoSpawnFits", "ParamsError", "Rejection",
    "SpawnCandidate", "SpawnDatabaseError", "SpawnDbError", "SpawnMatcher", "build_database",
    "carry_reviews", "database_path", "load_database", "mark_reviewed", "spawn_database",
    "write_database",
]

"""The spawn stage as the pipeline calls it, and which one a run uses: the :class:`Matcher`
protocol (``SpawnMatcher``, the spawn database's, is the built-in one) and the registry of
named matchers that ``scenweave run``, ``submit`` and ``worker`` take with ``--matcher``:
``default`` and what plugins declare as ``SPAWN_MATCHERS`` (``docs/plugins.md``), or
``module:callable``. A matcher is made by a callable from the map's name (None: Town04), once
per process and map.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol, cast

from scenweave.errors import InputError
from scenweave.plugins import DOCS, Registry, resolve

if TYPE_CHECKING:  # the protocol names the contract; naming a matcher needs no params
    from scenweave.schemas.params import Params


class Matcher(Protocol):
    """Places a record's params on the map: ``assign`` fills the spawn keys (and ``map``)
    from candidate ``index % len`` of the ``top_n`` spawn points that fit (round robin over
    the scenarios of a class). The pipeline, the batch runner and the queue take any object
    that has it; variants (``ingest.variants.vary``) are placed by a ``SpawnMatcher``."""

    def assign(self, params: Params, index: int, top_n: int = 5) -> Params:
        """``params`` with the spawn keys filled."""
        ...


#: makes a matcher for a map: a bundled town's name or an ``.xodr`` path (None: Town04)
MatcherFactory = Callable[[str | None], Matcher]

#: the matcher a run uses unless ``--matcher`` names another
DEFAULT_MATCHER = "default"
#: the built-in spawn matchers, declared as a plugin declares its own: the spawn database of
#: the run's map, built once and cached in ScenWeave's home (the shell knows where that is)
SPAWN_MATCHERS = {DEFAULT_MATCHER: "scenweave.runner:default_matcher"}

_factories: Registry[MatcherFactory] = Registry(
    "spawn matcher", "SPAWN_MATCHERS", expected="a callable making a matcher from a map name",
    accepts=callable, builtin_modules=[__name__])
_made: dict[tuple[MatcherFactory, str], Matcher] = {}


def matcher_names() -> list[str]:
    """Every spawn matcher's name: ``default`` and the plugins'."""
    return _factories.names()


def matcher_factory(name: str) -> MatcherFactory:
    """The callable making the matchers ``name`` names: a registered name or
    ``module:callable``; an :class:`InputError` naming ``--matcher`` and the choices."""
    found = _factories.find(name)
    if found is None and ":" in name:
        try:
            found = cast(MatcherFactory, resolve(name))
        except (ImportError, AttributeError) as err:
            raise InputError(f"--matcher {name}: {type(err).__name__}: {err}") from err
    if found is None:
        raise InputError(f"--matcher {name!r}: no such spawn matcher (choose "
                         f"{', '.join(matcher_names())} or give module:callable; plugins add "
                         f"more, see {DOCS})")
    return found


def matcher_for(name: str, map_name: str | None = None) -> Matcher:
    """The spawn matcher ``name`` (a registered name or ``module:callable``) makes for
    ``map_name``, made once per process (``default`` and the callable it names alike)."""
    from scenweave.roads import DEFAULT_MAP

    make = matcher_factory(name)
    key = (make, map_name or DEFAULT_MAP)
    if key not in _made:
        _made[key] = make(map_name)
    return _made[key]

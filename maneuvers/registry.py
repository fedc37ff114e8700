"""The manoeuvre registry: every class ScenWeave knows, built-in or added by a plugin.

Built-in classes come from this package's family modules; more come from the Python files or
modules named in ``$SCENWEAVE_MANEUVERS`` (separated by ``os.pathsep``), each defining
``MANEUVERS``, a sequence of :class:`Maneuver`. Worker processes inherit the variable, so a
plugin class runs everywhere the built-in ones do.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from types import ModuleType

from scenweave.errors import InputError
from scenweave.maneuvers.maneuver import Domain, Maneuver

PLUGINS_ENV = "SCENWEAVE_MANEUVERS"
BUILTIN_MODULES = ("brake", "cut", "lane_change", "follow", "free_ride", "urban")

_registry: dict[str, Maneuver] = {}
_builtin: set[str] = set()
#: plugin entry ($SCENWEAVE_MANEUVERS) -> the codes it registered
_loaded_plugins: dict[str, set[str]] = {}


class UnknownManeuver(InputError, KeyError):
    """A class code no definition registers; the message lists the known ones."""

    def __str__(self) -> str:
        return str(self.args[0])


def register(maneuver: Maneuver) -> Maneuver:
    """Add a class (a plugin's, or a test's); registering a code twice is an error."""
    _load()
    known = _registry.get(maneuver.code)
    if known is not None and known != maneuver:
        raise ValueError(f"manoeuvre class {maneuver.code} is already registered")
    _registry[maneuver.code] = maneuver
    return maneuver


def unregister(code: str) -> None:
    """Remove a class (tests that register a toy class clean up with this); a plugin whose
    classes are all gone is loaded again when $SCENWEAVE_MANEUVERS still names it."""
    _registry.pop(code, None)
    for entry, added in list(_loaded_plugins.items()):
        added.discard(code)
        if not added:
            del _loaded_plugins[entry]


def get(code: str) -> Maneuver:
    """The definition of ``code``; :class:`UnknownManeuver` names the known codes."""
    _load()
    try:
        return _registry[code]
    except KeyError:
        raise UnknownManeuver(f"unknown manoeuvre class {code!r} (known: {', '.join(codes())}; "
                              f"add one with ${PLUGINS_ENV}, see docs/adding-a-manoeuvre.md)"
                              ) from None


def find(code: object) -> Maneuver | None:
    """The definition of ``code``, or None for anything else (a missing or foreign code)."""
    _load()
    return _registry.get(code) if isinstance(code, str) else None


def maneuvers(domain: Domain | None = None) -> list[Maneuver]:
    """Every registered class (of one domain), sorted by code."""
    _load()
    return [m for _, m in sorted(_registry.items()) if domain in (None, m.domain)]


def codes(domain: Domain | None = None) -> list[str]:
    """The registered class codes (of one domain), sorted."""
    return [m.code for m in maneuvers(domain)]


def seeding_order(domain: Domain) -> list[Maneuver]:
    """The built-in classes by code, then the added ones by code: sample data seeded by
    position stays the same for the built-in classes whatever a plugin adds."""
    return sorted(maneuvers(domain), key=lambda m: (m.code not in _builtin, m.code))


def by_tag(tag: str) -> Maneuver | None:
    """The first class (by code) with corpus tag ``tag``."""
    return next((m for m in maneuvers() if m.tag == tag), None)


def _load() -> None:
    if not _builtin:
        for name in BUILTIN_MODULES:
            _add(importlib.import_module(f"scenweave.maneuvers.{name}"))
        _builtin.update(_registry)
    for entry in os.environ.get(PLUGINS_ENV, "").split(os.pathsep):
        if entry and entry not in _loaded_plugins:
            _loaded_plugins[entry] = _add(_import_plugin(entry))


def _add(module: ModuleType) -> set[str]:
    found: Iterable[Maneuver] | None = getattr(module, "MANEUVERS", None)
    if found is None:
        raise ImportError(f"{module.__name__} defines no MANEUVERS (a sequence of Maneuver)")
    added = set()
    for maneuver in found:
        if not isinstance(maneuver, Maneuver):
            raise TypeError(f"{module.__name__}: MANEUVERS holds {maneuver!r}, not a Maneuver")
        known = _registry.get(maneuver.code)
        if known is not None and known.code in _builtin | set().union(*_loaded_plugins.values()):
            raise ValueError(f"{module.__name__}: manoeuvre class {maneuver.code} is already "
                             "registered")
        _registry[maneuver.code] = maneuver
        added.add(maneuver.code)
    return added


def _import_plugin(entry: str) -> ModuleType:
    """A plugin named in $SCENWEAVE_MANEUVERS: a .py file or an importable module."""
    if not entry.endswith(".py"):
        return importlib.import_module(entry)
    path = Path(entry)
    name = f"scenweave_maneuver_plugin_{path.stem}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None or not path.is_file():
        raise ImportError(f"${PLUGINS_ENV}: no Python file {entry}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module

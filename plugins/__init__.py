"""Plugins: the one way to add to ScenWeave without changing it (``docs/plugins.md``).

A plugin is a Python module, a ``.py`` file or an importable module name, named in
``$SCENWEAVE_PLUGINS`` (several separated by ``os.pathsep``) or published by an installed
distribution in the entry-point group ``scenweave.plugins``. ScenWeave imports it on first use
and reads what it declares, each of these module-level names optional:

- ``MANEUVERS``: a sequence of :class:`~scenweave.maneuvers.Maneuver` (named by their codes);
- ``REPAIR_STRATEGIES``: name -> repair strategy (``--repair``);
- ``LLM_BACKENDS``: name -> a callable making the backend from the agent's settings (``--llm``);
- ``SPAWN_MATCHERS``: name -> a callable making a spawn matcher from a map name (``--matcher``).

A mapping's value may be ``"module:attribute"``, imported when it is first used. Each kind has
one :class:`Registry`, in the package that uses it, which the rest asks; it reads its built-in
modules exactly as it reads a plugin. This module is at the bottom of the layering (it imports
only the error root), so every package can keep its registry with it and plugins import it.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import os
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Generic, TypeVar, cast

from scenweave.errors import InputError

PLUGINS_ENV = "SCENWEAVE_PLUGINS"
ENTRY_POINT_GROUP = "scenweave.plugins"
#: the variable of the first plugin mechanism (manoeuvre classes only): read for one release
DEPRECATED_ENV = "SCENWEAVE_MANEUVERS"
DOCS = "docs/plugins.md"

T = TypeVar("T")


class PluginError(InputError):
    """A plugin cannot be loaded or declares something unusable: one line naming the plugin
    and where it was named."""


@dataclass(frozen=True)
class Plugin:
    """One plugin: what is imported (a ``.py`` path, a module, ``module:attribute``) and, for
    messages, where it was named."""

    target: str
    named_in: str = field(default=f"${PLUGINS_ENV}", compare=False)

    def error(self, problem: str) -> PluginError:
        return PluginError(one_line(f"plugin {self.target} (named in {self.named_in}): {problem}"))


#: the built-in declarations of a registry are read as a plugin is, under this name
BUILT_IN = "ScenWeave (built in)"
_modules: dict[str, object] = {}
_warned_deprecated = False


def one_line(text: str) -> str:
    return " ".join(text.split())


def active_plugins() -> list[Plugin]:
    """The plugins named now: ``$SCENWEAVE_PLUGINS``, then the deprecated
    ``$SCENWEAVE_MANEUVERS``, then the entry points; each target once."""
    named = [*_named_in(PLUGINS_ENV), *_deprecated_plugins(), *entry_point_plugins()]
    return list(dict.fromkeys(named))


def _named_in(variable: str) -> list[Plugin]:
    return [Plugin(entry, f"${variable}")
            for entry in os.environ.get(variable, "").split(os.pathsep) if entry]


def _deprecated_plugins() -> list[Plugin]:
    global _warned_deprecated
    found = _named_in(DEPRECATED_ENV)
    if found and not _warned_deprecated:
        _warned_deprecated = True
        warnings.warn(f"${DEPRECATED_ENV} is deprecated and goes in the next release: name "
                      f"the same plugins in ${PLUGINS_ENV} ({DOCS})", FutureWarning,
                      stacklevel=2)
    return found


@functools.cache
def entry_point_plugins() -> tuple[Plugin, ...]:
    """The installed distributions' plugins (group ``scenweave.plugins``), found once per
    process (``entry_point_plugins.cache_clear()`` looks again)."""
    return tuple(Plugin(point.value, f"entry point {point.name!r} of group {ENTRY_POINT_GROUP}")
                 for point in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP))


def loaded(plugin: Plugin) -> object:
    """The plugin's module (or the object ``module:attribute`` names), imported once."""
    if plugin.target not in _modules:
        try:
            _modules[plugin.target] = _import(plugin.target)
        except Exception as err:
            raise plugin.error(f"cannot be loaded: {type(err).__name__}: {err}") from err
    return _modules[plugin.target]


def _import(target: str) -> object:
    if target.endswith(".py"):
        return _import_file(Path(target))
    if ":" in target:
        return resolve(target)
    return importlib.import_module(target)


def _import_file(path: Path) -> object:
    if not path.is_file():
        raise FileNotFoundError(f"no Python file {path}")
    digest = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:8]
    name = f"scenweave_plugin_{path.stem}_{digest}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path} cannot be imported")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def resolve(reference: str) -> object:
    """The object ``"module:attribute"`` names (``attribute`` may be dotted)."""
    module_name, _, attribute = reference.partition(":")
    found: object = importlib.import_module(module_name)
    for part in attribute.split(".") if attribute else ():
        found = getattr(found, part)
    return found


class Registry(Generic[T]):
    """The named things of one kind: the built-in ones and those of the plugins named now.

    ``declared_as`` is the module-level name a built-in module or a plugin declares them by: a
    mapping name -> thing (or ``"module:attribute"``), or, with ``name_of``, a sequence of
    things that carry their names. A plugin no longer named takes its things with it."""

    def __init__(self, kind: str, declared_as: str, *, expected: str,
                 accepts: Callable[[object], bool], builtin_modules: Sequence[str] = (),
                 name_of: Callable[[T], str] | None = None,
                 normalize: Callable[[str], str] = str) -> None:
        self.kind, self.declared_as, self.expected = kind, declared_as, expected
        self._accepts, self._name_of, self._normalize = accepts, name_of, normalize
        self._builtin_modules = tuple(builtin_modules)
        self._entries: dict[str, T | str] = {}
        self._origin: dict[str, Plugin] = {}
        #: the plugins read into this registry -> the names each added
        self._read: dict[Plugin, set[str]] = {}
        self._builtin: set[str] = set()

    # --- asking -----------------------------------------------------------------------------

    def names(self) -> list[str]:
        """Every name known now, sorted."""
        self._sync()
        return sorted(self._entries)

    def find(self, name: str) -> T | None:
        """The thing called ``name`` (normalised), or None."""
        self._sync()
        key = self._normalize(name)
        return self._thing(key) if key in self._entries else None

    def things(self) -> list[T]:
        """Every thing known now, sorted by name."""
        self._sync()
        return [self._thing(key) for key in sorted(self._entries)]

    def _thing(self, key: str) -> T:
        entry = self._entries[key]
        if isinstance(entry, str):  # "module:attribute", imported now
            entry = self._checked(self._origin[key], f"{self.kind} {key!r} is",
                                  self._resolved(key, entry))
            self._entries[key] = entry
        return entry

    def is_builtin(self, name: str) -> bool:
        self._sync()
        return self._normalize(name) in self._builtin

    def origin(self, name: str) -> str:
        """Where ``name`` comes from: built in, a plugin, or registered by hand."""
        self._sync()
        return self._origin_text(self._normalize(name))

    def _origin_text(self, key: str) -> str:
        plugin = self._origin[key]
        return plugin.named_in if plugin.target == plugin.named_in else f"plugin {plugin.target}"

    # --- registering by hand (tests, programs embedding ScenWeave) -----------------------

    def register(self, name: str, thing: T) -> T:
        """Add ``thing`` under ``name``; a name already taken by something else is an error."""
        self._sync()
        key = self._normalize(name)
        if self._entries.get(key) is thing or (key in self._entries
                                                and self._entries[key] == thing):
            return thing
        here = Plugin("register()", "register()")
        self._add(here, key, self._checked(here, f"{self.kind} {key!r} is", thing))
        return thing

    def unregister(self, name: str) -> None:
        """Remove ``name``; a plugin whose things are all gone is read again while named."""
        key = self._normalize(name)
        self._entries.pop(key, None)
        self._origin.pop(key, None)
        for plugin, added in list(self._read.items()):
            added.discard(key)
            if not added and plugin.target != BUILT_IN:
                del self._read[plugin]

    # --- reading declarations -------------------------------------------------------------

    def _sync(self) -> None:
        if not self._builtin_modules_read():
            built_in = Plugin(BUILT_IN, BUILT_IN)
            added = set()
            for module_name in self._builtin_modules:
                added |= self._read_declarations(built_in, importlib.import_module(module_name))
            self._read[built_in] = added
            self._builtin = set(added)
        active = active_plugins()
        for plugin in set(self._read) - {*active, Plugin(BUILT_IN)}:
            for key in self._read.pop(plugin):
                self._entries.pop(key, None)
                self._origin.pop(key, None)
        for plugin in active:
            if plugin not in self._read:
                self._read[plugin] = self._read_declarations(plugin, loaded(plugin))

    def _builtin_modules_read(self) -> bool:
        return Plugin(BUILT_IN) in self._read

    def _read_declarations(self, plugin: Plugin, module: object) -> set[str]:
        declared = getattr(module, self.declared_as, None)
        if declared is None:
            return set()
        added: set[str] = set()
        try:
            for key, thing in self._declared_pairs(plugin, declared):
                self._add(plugin, key, thing)
                added.add(key)
        except PluginError:
            for key in added:  # all of a plugin's things or none
                self._entries.pop(key, None)
                self._origin.pop(key, None)
            raise
        return added

    def _declared_pairs(self, plugin: Plugin, declared: object) -> Iterable[tuple[str, T | str]]:
        if self._name_of is not None:
            if isinstance(declared, Mapping | str) or not isinstance(declared, Iterable):
                raise plugin.error(f"{self.declared_as} must be a sequence of {self.expected}")
            name_of = self._name_of
            checked = [self._checked(plugin, f"{self.declared_as} holds", thing)
                       for thing in declared]
            return [(self._normalize(name_of(thing)), thing) for thing in checked]
        if not isinstance(declared, Mapping):
            raise plugin.error(f"{self.declared_as} must be a mapping name -> {self.expected}")
        return [(self._normalize(str(name)),
                 thing if isinstance(thing, str) else
                 self._checked(plugin, f"{self.declared_as}[{name!r}] is", thing))
                for name, thing in declared.items()]

    def _add(self, plugin: Plugin, key: str, thing: T | str) -> None:
        if key in self._entries:
            raise plugin.error(f"{self.kind} {key!r} is already registered (by "
                               f"{self._origin_text(key)})")
        self._entries[key] = thing
        self._origin[key] = plugin

    def _checked(self, plugin: Plugin, what: str, thing: object) -> T:
        """``thing`` if it is of this kind; else ``what`` ("MANEUVERS holds") tells."""
        if not self._accepts(thing):
            raise plugin.error(f"{what} {thing!r}, not {self.expected}")
        return cast(T, thing)

    def _resolved(self, key: str, reference: str) -> object:
        plugin = self._origin[key]
        try:
            return resolve(reference)
        except Exception as err:
            raise plugin.error(f"{self.kind} {key!r}: {reference} cannot be loaded: "
                               f"{type(err).__name__}: {err}") from err

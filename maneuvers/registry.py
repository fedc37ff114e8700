"""The manoeuvre registry: every class ScenWeave knows, built-in or added by a plugin.

Built-in classes come from this package's family modules, each declaring ``MANEUVERS`` (a
sequence of :class:`Maneuver`); a plugin (``docs/plugins.md``: a module named in
``$SCENWEAVE_PLUGINS`` or by an entry point) declares its classes the same way. Worker
processes inherit the variable, so a plugin class runs everywhere the built-in ones do.
"""

from __future__ import annotations

from scenweave.errors import InputError
from scenweave.maneuvers.maneuver import Domain, Maneuver
from scenweave.plugins import DOCS, PLUGINS_ENV, Registry

__all__ = ["PLUGINS_ENV", "UnknownManeuver", "by_tag", "codes", "find", "get", "is_builtin",
           "maneuvers", "register", "seeding_order", "unregister"]

BUILTIN_MODULES = ("brake", "cut", "lane_change", "follow", "free_ride", "urban")


def _code(maneuver: Maneuver) -> str:
    return maneuver.code


_classes: Registry[Maneuver] = Registry(
    "manoeuvre class", "MANEUVERS", expected="a Maneuver",
    accepts=lambda thing: isinstance(thing, Maneuver), name_of=_code,
    builtin_modules=[f"scenweave.maneuvers.{name}" for name in BUILTIN_MODULES])


class UnknownManeuver(InputError, KeyError):
    """A class code no definition registers; the message lists the known ones."""

    def __str__(self) -> str:
        return str(self.args[0])


def register(maneuver: Maneuver) -> Maneuver:
    """Add a class by hand (a test's); registering a taken code for another class is an
    error."""
    return _classes.register(maneuver.code, maneuver)


def unregister(code: str) -> None:
    """Remove a class (tests that register a toy class clean up with this); a plugin whose
    classes are all gone is read again while it is still named."""
    _classes.unregister(code)


def get(code: str) -> Maneuver:
    """The definition of ``code``; :class:`UnknownManeuver` names the known codes."""
    found = _classes.find(code)
    if found is None:
        raise UnknownManeuver(f"unknown manoeuvre class {code!r} (known: {', '.join(codes())}; "
                              f"add one with a plugin in ${PLUGINS_ENV}, see {DOCS})")
    return found


def find(code: object) -> Maneuver | None:
    """The definition of ``code``, or None for anything else (a missing or foreign code)."""
    return _classes.find(code) if isinstance(code, str) else None


def maneuvers(domain: Domain | None = None) -> list[Maneuver]:
    """Every registered class (of one domain), sorted by code."""
    return [m for m in _classes.things() if domain in (None, m.domain)]


def codes(domain: Domain | None = None) -> list[str]:
    """The registered class codes (of one domain), sorted."""
    return [m.code for m in maneuvers(domain)]


def is_builtin(code: str) -> bool:
    """True for a class ScenWeave ships; False for a plugin's or one registered by hand
    (the docs' tables count only the built-in ones, ``scripts/doc_tables.py``)."""
    return _classes.is_builtin(code)


def seeding_order(domain: Domain) -> list[Maneuver]:
    """The built-in classes by code, then the added ones by code: sample data seeded by
    position stays the same for the built-in classes whatever a plugin adds."""
    return sorted(maneuvers(domain), key=lambda m: (not is_builtin(m.code), m.code))


def by_tag(tag: str) -> Maneuver | None:
    """The first class (by code) with corpus tag ``tag``."""
    return next((m for m in maneuvers() if m.tag == tag), None)

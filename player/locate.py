"""Where the esmini player is: ``$ESMINI_HOME``, then the workplace copy, then setup's install.

``find_esmini()`` answers with an :class:`EsminiInstall` (library path, version, which source
it came from) or raises :class:`PlayerUnavailable` saying what was tried and why each place
did not hold it. The order is the one ``scripts/setup.d/10-esmini.sh`` follows: when neither
of the first two exists, setup builds ``$ESMINI_SOURCE_ARCHIVE`` or fetches esmini's release
archive into ``/opt/scenweave/esmini`` (``$SCENWEAVE_ESMINI_PREFIX`` moves it, for setup and
for this search alike). ``$SCENWEAVE_WORKPLACE_ESMINI`` moves the workplace copy's place (a
folder without esmini there: the machine as a user's clone sees it, for tests and checks).
"""

from __future__ import annotations

import ctypes
import os
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from scenweave.player.errors import PlayerUnavailable

LIBRARY = "libesminiLib.so"
#: where scripts/setup.d/10-esmini.sh installs a build made from a source or release archive
INSTALLED_HOME = Path("/opt/scenweave/esmini")
#: the workplace's headless build, beside the repository (absent in users' clones)
WORKPLACE_HOME = Path(__file__).resolve().parents[2] / "shared" / "esmini"
#: moves the workplace copy's place (``workplace_home()``)
WORKPLACE_ENV = "SCENWEAVE_WORKPLACE_ESMINI"
#: esmini_build_version(), C++ name mangling (it is not declared extern "C")
BUILD_VERSION_SYMBOL = "_Z20esmini_build_versionv"


@dataclass(frozen=True)
class EsminiInstall:
    """One esmini installation: its home folder, its library and where it was found."""

    home: Path
    library: Path
    source: str

    @property
    def version(self) -> str:
        return library_version(self.library)

    def to_dict(self) -> dict[str, str]:
        return {"home": str(self.home), "library": str(self.library), "source": self.source,
                "version": self.version}


def installed_home() -> Path:
    """Where setup installs a build or release: ``$SCENWEAVE_ESMINI_PREFIX`` or the default."""
    return Path(os.environ.get("SCENWEAVE_ESMINI_PREFIX") or INSTALLED_HOME)


def workplace_home() -> Path:
    """The workplace copy's place: ``$SCENWEAVE_WORKPLACE_ESMINI`` or ``../shared/esmini``."""
    return Path(os.environ.get(WORKPLACE_ENV) or WORKPLACE_HOME)


def candidates() -> list[tuple[str, Path]]:
    """The places looked at, in order: ``(source, home folder)``."""
    places = []
    if os.environ.get("ESMINI_HOME"):
        places.append(("ESMINI_HOME", Path(os.environ["ESMINI_HOME"]).expanduser()))
    places.append((f"workplace build ({workplace_home()})", workplace_home()))
    installed = installed_home()
    places.append((f"setup's install ({installed})", installed))
    return places


def find_esmini() -> EsminiInstall:
    """The first installation holding ``bin/libesminiLib.so``; else PlayerUnavailable."""
    tried = [] if os.environ.get("ESMINI_HOME") else ["ESMINI_HOME: unset"]
    for source, home in candidates():
        library = home / "bin" / LIBRARY
        if library.is_file():
            return EsminiInstall(home, library, source)
        tried.append(f"{source}: no {library}")
    raise PlayerUnavailable(
        "esmini not found (" + "; ".join(tried) + "); set ESMINI_HOME to an esmini folder "
        "with bin/libesminiLib.so, or run scripts/setup.sh with ESMINI_SOURCE_ARCHIVE set")


@cache
def library_version(library: Path) -> str:
    """The build version the library reports (``v3.6.0-131a5651``), or ``unknown``.

    esmini exports it only as a C++ function, ``esmini_build_version()``; loading the library
    runs no scenario code.
    """
    try:
        function = getattr(ctypes.CDLL(str(library)), BUILD_VERSION_SYMBOL)
    except (OSError, AttributeError):
        return "unknown"
    function.restype = ctypes.c_char_p
    return (function() or b"unknown").decode(errors="replace")

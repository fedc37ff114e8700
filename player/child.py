"""The command line of a child process that runs one function of a player module without the
player package's ``__init__`` (which imports the whole player, numpy and lxml: 0.2 s more for
every child started)."""

from __future__ import annotations

import sys
from pathlib import Path

#: registers ``scenweave.player`` as a bare package (this folder, no ``__init__`` run), then
#: imports the module and calls the function with the remaining arguments
PROGRAM = """
import sys, types
import scenweave
package = types.ModuleType("scenweave.player")
package.__path__ = [sys.argv[1]]
sys.modules["scenweave.player"] = package
from scenweave.player.{module} import {function}
{function}(*sys.argv[2:])
"""


def bare_child_command(module: str, function: str, *args: str) -> list[str]:
    """``[python, -c, program, ...]`` running ``scenweave.player.<module>.<function>(*args)``."""
    program = PROGRAM.format(module=module, function=function)
    return [sys.executable, "-c", program, str(Path(__file__).resolve().parent), *args]

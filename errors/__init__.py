"""The one root of ScenWeave's exceptions and its three branches; callers route on them.

- :class:`InputError`: what the user gave cannot be used (a record, a file, an option, a
  map); the message names the file, row, field or option. A batch reports it and goes on.
- :class:`ScenarioError`: one scenario cannot be made (no spawn point fits, a params value a
  script cannot build from, an LLM's edit that does not apply). It is that scenario's
  ``failed`` outcome; the batch goes on.
- :class:`InfrastructureError`: the machine or a service fails (the esmini engine, the
  sandbox, the LLM server, the queue, a package's data). The run stops (the queue worker
  retries the scenario later); the message names the setting to change.

Every package's own root (``SandboxError``, ``PlayerError``, ``SpawnDbError``...) derives
from one branch, or from the root when its children differ. This package is the bottom of the
stack and imports nothing. The one package outside the tree is what LLM-written scripts import
inside the sandbox (``scenario_lib/``: ``builder.py`` and ``phases.py``, where only that folder
is mounted): their errors stay plain ``ValueError``s, which the scripts' failures report as
values anyway.
"""

from __future__ import annotations


class ScenWeaveError(Exception):
    """Root of every exception ScenWeave raises on purpose."""


class InputError(ScenWeaveError):
    """Input that cannot be used; the message names the file, row, field or option."""


class ScenarioError(ScenWeaveError):
    """One scenario cannot be made; it fails, the batch goes on."""


class InfrastructureError(ScenWeaveError):
    """The machine or a service fails; the run stops and the message names what to change."""


class ParamsError(ScenarioError, ValueError):
    """A params dict a stage cannot build the scenario from (the spawn stage, a reference
    script): a key missing or holding the wrong kind of value; the message names the key."""


__all__ = ["InfrastructureError", "InputError", "ParamsError", "ScenWeaveError", "ScenarioError"]

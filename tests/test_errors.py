"""One error root (``scenweave.errors``): every exception ScenWeave raises on purpose derives
from it through one of three branches, and the pipeline routes on those types, not on names."""

from __future__ import annotations

import ast
import importlib

import pytest

from scenweave.errors import InfrastructureError, InputError, ScenarioError, ScenWeaveError
from scenweave.pipeline import is_infrastructure_error
from tests.test_layering import MODULES

#: exceptions outside the tree, and why
OUTSIDE = {
    # imported by LLM-written scripts inside the sandbox, where only `scenario_lib` is mounted
    "scenweave.scenario_lib.phases.PhasesInvalid",
    # Ctrl-C: it must stay a KeyboardInterrupt for click and the shell
    "scenweave.run_folder.RunInterrupted",
}


def _exception_classes() -> list[str]:
    found = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and any(
                    isinstance(b, ast.Name) and (b.id.endswith(("Error", "Exception", "Interrupt"))
                                                 or b.id in ("ValueError", "RuntimeError"))
                    for b in node.bases):
                found.append(f"{module}.{node.name}")
    return found


def _class(dotted: str) -> type:
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def test_the_exceptions_outside_the_tree_are_the_ones_named():
    found = set(_exception_classes())
    assert found >= OUTSIDE
    assert not any(issubclass(_class(dotted), ScenWeaveError) for dotted in OUTSIDE)


@pytest.mark.parametrize("dotted", sorted(set(_exception_classes()) - OUTSIDE))
def test_every_exception_of_ours_has_the_one_root(dotted):
    module, _, name = dotted.rpartition(".")
    err_type = getattr(importlib.import_module(module), name)
    assert issubclass(err_type, ScenWeaveError), dotted
    assert err_type in (InputError, ScenarioError, InfrastructureError, ScenWeaveError) or any(
        issubclass(err_type, branch) for branch in (InputError, ScenarioError,
                                                    InfrastructureError)) or (
        # a package root whose children take different branches
        err_type.__bases__ == (ScenWeaveError,)), dotted


@pytest.mark.parametrize("dotted, branch", [
    ("scenweave.sandbox.SandboxUnavailable", InfrastructureError),
    ("scenweave.player.PlayerUnavailable", InfrastructureError),
    ("scenweave.agent.llm.base.LLMTimeout", InfrastructureError),
    ("scenweave.queue.connection.QueueError", InfrastructureError),
    ("scenweave.spawn_db.NoSpawnFits", ScenarioError),
    ("scenweave.agent.code.PatchError", ScenarioError),
    ("scenweave.ingest.issues.RecordIssue", InputError),
    ("scenweave.roads.UnknownMapError", InputError),
    ("scenweave.schemas.params.ParamsInvalid", InputError),
])
def test_the_branches_say_what_a_caller_does(dotted, branch):
    module, _, name = dotted.rpartition(".")
    assert issubclass(getattr(importlib.import_module(module), name), branch)


def test_the_pipeline_routes_on_the_type_not_the_name():
    class Renamed(InfrastructureError):
        """An infrastructure failure whose name says nothing (a plugin's)."""

    class SpawnLikeName(ScenarioError):
        """A scenario failure named like something else."""

    assert is_infrastructure_error(Renamed("the engine is gone"))
    assert not is_infrastructure_error(SpawnLikeName("no"))
    assert is_infrastructure_error(ConnectionRefusedError())

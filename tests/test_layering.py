"""The layering the README promises, read from the source: imports flow downward, no package
has an import cycle among its own modules, and no broken import is silently swallowed."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
UPPER = ("scenweave", "ingest", "agent", "mining", "viewer")
BOTTOM = ("corpus", "sandbox", "schemas", "judge", "spawn_db", "player", "roads", "maneuvers",
          "scenario_lib", "plugins", "files", "errors")
#: our top-level folders, installed as ``scenweave.<folder>`` (``scenweave/`` is the shell)
FOLDERS = (*UPPER, *BOTTOM)


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    dotted = ".".join(parts).removesuffix(".__init__")
    return dotted if parts[0] == "scenweave" else f"scenweave.{dotted}"


def layer(module: str) -> str:
    """The folder a module lives in: ``scenweave.agent.graph`` -> agent, ``scenweave.cli``
    -> scenweave."""
    second = module.split(".")[1] if "." in module else ""
    return second if second in BOTTOM or second in UPPER[1:] else "scenweave"


def _modules() -> dict[str, Path]:
    return {_module_name(path): path
            for folder in FOLDERS for path in (ROOT / folder).rglob("*.py")}


MODULES = _modules()


def _imports(path: Path) -> set[str]:
    """Every project module ``path`` imports, at the top or inside a function."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # `from scenweave import corpus` depends on scenweave.corpus, not on the shell
            module = [] if node.module == "scenweave" else [node.module]
            names = [*module, *(f"{node.module}.{alias.name}" for alias in node.names)]
        else:
            continue
        for name in names:
            while name and name not in MODULES:
                name = name.rpartition(".")[0]
            if name:
                found.add(name)
    return found


GRAPH = {name: _imports(path) - {name} for name, path in MODULES.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            step = next(edges, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = len(index)
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(sorted(graph[step]))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


@pytest.mark.parametrize("package", [*UPPER, *BOTTOM])
def test_no_import_cycle_among_a_packages_modules(package):
    own = {name: {target for target in targets if layer(target) == package
                  and not name.startswith(target + ".")}
           for name, targets in GRAPH.items() if layer(name) == package}
    assert _cycles(own) == []


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


@pytest.mark.parametrize("package", BOTTOM)
def test_bottom_packages_never_import_the_upper_ones(package):
    upward = sorted((name, target) for name, targets in GRAPH.items()
                    if layer(name) == package
                    for target in targets if layer(target) in UPPER)
    assert upward == []


def test_the_packages_import_each_other_without_a_cycle():
    """Package by package, the imports form layers: shell, ingest/agent, corpus/sandbox/schemas
    /spawn_db/player, maneuvers (schemas -> spawn_db was once also spawn_db -> schemas)."""
    packages = {package: {layer(target) for name, targets in GRAPH.items()
                          if layer(name) == package for target in targets} - {package}
                for package in FOLDERS}
    assert _cycles(packages) == []


@pytest.mark.parametrize("package, below", [("maneuvers", {"errors", "plugins"}),
                                            ("plugins", {"errors"}), ("files", set()),
                                            ("errors", set()), ("roads", {"errors", "files"}),
                                            ("scenario_lib", set())])
def test_the_bottom_layer_imports_nothing_of_ours_but_the_error_root(package, below):
    assert {layer(target) for name, targets in GRAPH.items() if layer(name) == package
            for target in targets} <= {package, *below}


def test_the_road_model_reads_no_recording_format():
    """roads/ writes recorded lane networks from its own neutral model (LaneStrip); reading a
    format into it (CommonRoad, highD) is the mining readers' job."""
    readers = [name for name in MODULES if layer(name) == "roads" and any(
        isinstance(node, (ast.Import, ast.ImportFrom)) and "commonroad" in ast.unparse(node)
        for node in ast.walk(ast.parse(MODULES[name].read_text(encoding="utf-8"))))]
    assert readers == []


#: the shell by job: folder -> the shell modules outside it that it may import. The
#: presentation (reports, charts, figures) reads run folders and imports no other job; the
#: queue builds on the batch runner and writes the report; the CLI's commands are above both
SHELL_JOBS = {
    "scenweave.presentation": {"scenweave.run_folder"},
    "scenweave.queue": {"scenweave.run_folder", "scenweave.runner", "scenweave.pipeline",
                        "scenweave.inputs", "scenweave.progress", "scenweave.presentation"},
}


def _shell_job(module: str) -> str:
    return next((job for job in (*SHELL_JOBS, "scenweave.commands")
                 if module == job or module.startswith(job + ".")), module)


@pytest.mark.parametrize("job", SHELL_JOBS)
def test_each_job_of_the_shell_imports_only_what_it_builds_on(job):
    assert any(_shell_job(name) == job for name in MODULES), f"{job} has no module"
    outside = sorted((name, target) for name, targets in GRAPH.items()
                     if _shell_job(name) == job for target in targets
                     if layer(target) == "scenweave" and _shell_job(target) != job
                     and _shell_job(target) not in SHELL_JOBS[job])
    assert outside == []


def test_only_the_commands_and_the_queue_import_the_queue():
    """The batch runner, the pipeline and the presentation never import the queue: a
    ``scenweave run`` needs no Redis, and the queue's jobs call the runner, not the reverse
    (the fault suite's process driver, ``scenweave.testing.faults``, drives the queue)."""
    users = sorted({_shell_job(name) for name, targets in GRAPH.items()
                    if any(_shell_job(t) == "scenweave.queue" for t in targets)})
    assert set(users) <= {"scenweave.queue", "scenweave.commands",
                          "scenweave.testing.faults"}, users


def test_the_scenario_library_imports_only_what_the_sandbox_mounts():
    """LLM-written scripts import ``scenario_lib.builder`` (and so the ``scenario_lib`` package)
    in the sandbox, where only the ``scenario_lib`` folder exists: nothing any of its modules
    loads may leave it (not even the error root)."""
    reached = set()
    todo = [name for name in MODULES if layer(name) == "scenario_lib"]
    assert "scenweave.scenario_lib.builder" in todo
    while todo:
        name = todo.pop()
        if name not in reached:
            reached.add(name)
            todo += GRAPH[name]
    assert {layer(name) for name in reached} == {"scenario_lib"}, sorted(reached)


def test_the_scenario_library_package_imports_nothing():
    """The sandbox imports ``scenweave.scenario_lib`` before any module of it."""
    tree = ast.parse((ROOT / "scenario_lib" / "__init__.py").read_text(encoding="utf-8"))
    assert [node for node in ast.walk(tree) if isinstance(node, ast.Import | ast.ImportFrom)
            and not (isinstance(node, ast.ImportFrom) and node.module == "__future__")] == []


def test_the_corpus_builds_on_the_scenario_library():
    """The reference scripts import the scenario library; it never imports the corpus."""
    used = {target for name, targets in GRAPH.items() if layer(name) == "corpus"
            for target in targets if layer(target) == "scenario_lib"}
    assert "scenweave.scenario_lib.builder" in used
    assert [(name, target) for name, targets in GRAPH.items() if layer(name) == "scenario_lib"
            for target in targets if layer(target) == "corpus"] == []


def test_the_agent_is_handed_placed_params_and_places_nothing():
    """The spawn stage and the variants (``ingest.variants.vary``) run before the agent, in
    the pipeline: the agent adapts scripts to the params it is given and imports neither
    ``ingest`` nor ``spawn_db``."""
    reached = sorted((name, target) for name, targets in GRAPH.items() if layer(name) == "agent"
                     for target in targets if layer(target) in ("ingest", "spawn_db"))
    assert reached == []


def test_no_package_imports_another_packages_private_names():
    private = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.module and node.level == 0):
                continue
            if node.module in MODULES and layer(node.module) != layer(name):
                private += [f"{name} imports {node.module}.{alias.name}"
                            for alias in node.names if alias.name.startswith("_")]
    assert private == []


#: modules that may answer an ImportError with a value, and why
EXPECTED_IMPORT_ERRORS = {
    # it imports what an LLM-written script names, to suggest a correction: a module that
    # does not exist is an answer there, not a broken import of ScenWeave's
    "scenweave.agent.repair.code_corrections",
}


def test_no_import_error_is_swallowed():
    """A handler of ImportError must raise (naming what to install), never return or pass."""
    quiet = []
    for name, path in MODULES.items():
        if name in EXPECTED_IMPORT_ERRORS:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            catches = isinstance(node, ast.ExceptHandler) and "ImportError" in ast.unparse(
                node.type or ast.Name("BaseException"))
            if catches and not any(isinstance(child, ast.Raise) for child in ast.walk(node)):
                quiet.append(f"{name}:{node.lineno}")
    assert quiet == []


def test_every_import_of_ours_goes_through_the_scenweave_namespace():
    """``import agent`` works only from a checkout; installed there is only ``scenweave``."""
    bare = []
    for path in ROOT.rglob("*.py"):
        if path.relative_to(ROOT).parts[0] in (".venv", "build"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.module
                     and node.level == 0 else [])
            bare += [f"{path.relative_to(ROOT)}:{node.lineno} {name}" for name in names
                     if name.split(".")[0] in FOLDERS[1:]]
    assert bare == []


def test_only_the_spawn_review_picture_imports_matplotlib():
    """matplotlib is the optional ``plot`` extra: one drawing (``spawn-db show``) needs it."""
    users = sorted({name for name, path in MODULES.items()
                   for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
                   if isinstance(node, ast.Import | ast.ImportFrom)
                   and any(n.split(".")[0] == "matplotlib" for n in (
                       [a.name for a in node.names] if isinstance(node, ast.Import)
                       else [node.module or ""]))})
    assert users == ["scenweave.spawn_db.map_plot"]

"""One plugin mechanism (docs/plugins.md): a module named in $SCENWEAVE_PLUGINS or by an entry
point of group ``scenweave.plugins`` adds repair strategies, LLM backends, spawn matchers and
manoeuvre classes, each kind asked by its name where the built-in ones are; a plugin that
cannot be used says so in one line naming it and where it was named."""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import pytest

from scenweave import maneuvers, plugins
from scenweave.agent import AgentSettings
from scenweave.agent.llm import backend_names, get_llm
from scenweave.agent.repair import get_strategy, strategy_names
from scenweave.cli import main
from scenweave.errors import InputError
from scenweave.spawn_db.registry import matcher_factory, matcher_for, matcher_names

TOY = Path(__file__).with_name("toy_plugin.py")


def write_plugin(folder: Path, name: str, source: str) -> Path:
    path = folder / f"{name}.py"
    path.write_text(textwrap.dedent(source), encoding="utf-8")
    return path


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.setenv(plugins.PLUGINS_ENV, str(TOY))


@pytest.fixture
def entry_points(monkeypatch, tmp_path):
    """An installed distribution of our own: ``tmp_path`` on sys.path with its dist-info,
    whose entry points of group scenweave.plugins are ``points`` (name -> module)."""
    def install(**points: str) -> None:
        info = tmp_path / "scenweave_toy_dist-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: scenweave-toy-dist\n"
                                       "Version: 0.1\n", encoding="utf-8")
        lines = [f"{name} = {target}" for name, target in points.items()]
        (info / "entry_points.txt").write_text(
            "\n".join([f"[{plugins.ENTRY_POINT_GROUP}]", *lines, ""]), encoding="utf-8")
        monkeypatch.syspath_prepend(str(tmp_path))
        plugins.entry_point_plugins.cache_clear()

    yield install
    plugins.entry_point_plugins.cache_clear()


def test_a_plugins_repair_strategy_and_llm_backend_are_picked_by_name(toy):
    settings = AgentSettings(llm="echo", repair="reference-only")
    assert settings.repair == "reference_only"
    assert "reference_only" in strategy_names() and "echo" in backend_names()
    strategy = get_strategy(settings.repair)
    assert type(strategy).__name__ == "Reference"
    llm = get_llm(settings)
    assert (llm.backend, llm.model) == ("echo", "echo")
    from scenweave.agent.repair import Request

    assert strategy.repair(Request({}, "print('reference')", []), llm).code == (
        "print('reference')")


def test_the_llm_option_takes_a_plugins_backend_and_refuses_an_unknown_name(toy, tmp_path,
                                                                            capsys):
    from scenweave.commands.agent_options import LlmChoice

    assert LlmChoice().convert("echo", None, None) == "echo"
    with pytest.raises(SystemExit) as refused:
        main(["run", str(tmp_path), "--llm", "nosuch"])
    assert refused.value.code == 2
    err = capsys.readouterr().err
    assert "'nosuch' is not one of auto, embedded, ollama, replay, none" in err
    assert "echo" in err  # the plugin's backend is listed among the choices


def test_the_built_in_ones_stay_and_a_plugin_no_longer_named_takes_its_own_with_it(
        toy, monkeypatch):
    assert {"code_corrections", "error_feedback", "patch", "reference_only"} <= set(
        strategy_names())
    assert {"embedded", "ollama", "replay", "echo"} <= set(backend_names())
    monkeypatch.delenv(plugins.PLUGINS_ENV)
    assert strategy_names() == ["code_corrections", "error_feedback", "patch"]
    assert backend_names() == ["embedded", "ollama", "replay"]
    with pytest.raises(ValueError, match=r"--repair 'reference-only': no such repair strategy "
                                         r"\(choose code-corrections, error-feedback, patch; "
                                         r"plugins add more, see docs/plugins.md\)"):
        AgentSettings(llm="replay", repair="reference-only")


def test_an_entry_point_plugin_is_found(entry_points, tmp_path):
    write_plugin(tmp_path, "scenweave_toy_matchers", """
        MADE = []

        def make_matcher(map_name):
            MADE.append(map_name)
            return ("toy matcher", map_name)

        SPAWN_MATCHERS = {"toy-ep": "scenweave_toy_matchers:make_matcher"}
    """)
    assert "toy-ep" not in matcher_names()
    entry_points(toy="scenweave_toy_matchers")
    assert matcher_names() == ["default", "toy-ep"]
    assert matcher_for("toy-ep", "Town06") == ("toy matcher", "Town06")
    assert matcher_for("toy-ep", "Town06") == ("toy matcher", "Town06")
    import scenweave_toy_matchers

    assert scenweave_toy_matchers.MADE == ["Town06"], "made once per process"


def test_an_entry_point_may_add_a_manoeuvre_class(entry_points):
    entry_points(accel="tests.maneuvers.toy.accel")
    try:
        assert maneuvers.get("ACCEL").tag == "lead_accelerates"
    finally:
        maneuvers.unregister("ACCEL")


def test_the_matcher_option_takes_a_name_or_module_callable(tmp_path, capsys):
    assert matcher_factory("default") is matcher_factory("scenweave.runner:default_matcher")
    with pytest.raises(InputError, match="--matcher scenweave.runner:nothing: AttributeError"):
        matcher_factory("scenweave.runner:nothing")
    with pytest.raises(SystemExit) as exited:
        main(["submit", str(tmp_path), "--queue", "redis://127.0.0.1:1/0", "--matcher", "nope"])
    assert exited.value.code == 2
    assert "--matcher 'nope': no such spawn matcher (choose default or give module:callable" in (
        capsys.readouterr().err)


def broken_message(raised: pytest.ExceptionInfo) -> str:
    message = str(raised.value)
    assert isinstance(raised.value, InputError) and "\n" not in message
    return message


def test_a_plugin_that_fails_to_import_is_one_line_naming_it_and_the_variable(
        monkeypatch, tmp_path):
    broken = write_plugin(tmp_path, "broken", """
        raise RuntimeError("the author's mistake\\non two lines")
    """)
    monkeypatch.setenv(plugins.PLUGINS_ENV, os.pathsep.join([str(TOY), str(broken)]))
    with pytest.raises(plugins.PluginError) as raised:
        strategy_names()
    assert broken_message(raised) == (
        f"plugin {broken} (named in $SCENWEAVE_PLUGINS): cannot be loaded: RuntimeError: the "
        "author's mistake on two lines")


def test_the_command_line_shows_a_broken_plugin_in_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(plugins.PLUGINS_ENV, str(tmp_path / "missing.py"))
    with pytest.raises(SystemExit):
        main(["sample-data", str(tmp_path / "raw"), "--per-class", "1"])
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert (f"PluginError: plugin {tmp_path / 'missing.py'} (named in $SCENWEAVE_PLUGINS): "
            f"cannot be loaded: FileNotFoundError: no Python file") in err


@pytest.mark.parametrize("source, problem", [
    ('REPAIR_STRATEGIES = {"x": 3}',
     "REPAIR_STRATEGIES['x'] is 3, not a RepairStrategy"),
    ('REPAIR_STRATEGIES = ["patch"]',
     "REPAIR_STRATEGIES must be a mapping name -> a RepairStrategy"),
    ("from scenweave.agent.repair.patch import STRATEGY\n"
     'REPAIR_STRATEGIES = {"patch": STRATEGY}',
     "repair strategy 'patch' is already registered (by ScenWeave (built in))"),
])
def test_a_plugin_declaring_what_cannot_be_used_is_named(monkeypatch, tmp_path, source,
                                                         problem):
    plugin = write_plugin(tmp_path, "odd", source)
    monkeypatch.setenv(plugins.PLUGINS_ENV, str(plugin))
    with pytest.raises(plugins.PluginError) as raised:
        strategy_names()
    assert broken_message(raised) == f"plugin {plugin} (named in $SCENWEAVE_PLUGINS): {problem}"


def test_a_reference_that_cannot_be_imported_names_the_plugin_when_it_is_used(monkeypatch,
                                                                              tmp_path):
    plugin = write_plugin(tmp_path, "ghost", 'LLM_BACKENDS = {"ghost": "no_such_module:LLM"}')
    monkeypatch.setenv(plugins.PLUGINS_ENV, str(plugin))
    assert "ghost" in backend_names()  # declared: imported only when used
    with pytest.raises(plugins.PluginError) as raised:
        get_llm(AgentSettings(llm="ghost"))
    assert broken_message(raised).startswith(
        f"plugin {plugin} (named in $SCENWEAVE_PLUGINS): LLM backend 'ghost': no_such_module:LLM "
        "cannot be loaded: ModuleNotFoundError")


def test_a_broken_entry_point_names_its_group(entry_points):
    entry_points(gone="scenweave_no_such_plugin")
    with pytest.raises(plugins.PluginError) as raised:
        maneuvers.codes()
    assert broken_message(raised).startswith(
        "plugin scenweave_no_such_plugin (named in entry point 'gone' of group "
        "scenweave.plugins): cannot be loaded: ModuleNotFoundError")

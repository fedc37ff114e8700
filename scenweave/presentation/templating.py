"""The Jinja2 templates of ``presentation/templates``: one environment, every value escaped.

The run and mining reports (``report``) and the replay figures (``replay_figures``) render
from it, so a record's text can only ever be shown, never run, in HTML and in SVG alike.
"""

from __future__ import annotations

import functools
from typing import Any

import jinja2


@functools.cache
def templates() -> jinja2.Environment:
    """The templates (``presentation/templates``), every value escaped for HTML and XML;
    compiled once per template version, not once per process (``compiled_cache``)."""
    return jinja2.Environment(loader=jinja2.PackageLoader("scenweave.presentation", "templates"),
                              autoescape=True, trim_blocks=True, lstrip_blocks=True,
                              undefined=jinja2.StrictUndefined, bytecode_cache=compiled_cache())


def compiled_cache() -> jinja2.BytecodeCache | None:
    """The compiled templates kept in ``$SCENWEAVE_HOME/cache/templates`` (keyed by each
    template's source, written by rename): compiling them cost every run's report and every
    worker's first replay figure 0.3-0.9 s. None where that folder cannot be made."""
    from scenweave.agent.home import home

    try:
        folder = home() / "cache" / "templates"
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return jinja2.FileSystemBytecodeCache(str(folder))


def render(template: str, **context: Any) -> str:
    """A template of ``presentation/templates`` rendered with ``context``."""
    return templates().get_template(template).render(**context)

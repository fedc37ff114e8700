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
    """The templates (``presentation/templates``), every value escaped for HTML and XML."""
    return jinja2.Environment(loader=jinja2.PackageLoader("scenweave.presentation", "templates"),
                              autoescape=True, trim_blocks=True, lstrip_blocks=True,
                              undefined=jinja2.StrictUndefined)


def render(template: str, **context: Any) -> str:
    """A template of ``presentation/templates`` rendered with ``context``."""
    return templates().get_template(template).render(**context)

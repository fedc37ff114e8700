"""``scenweave view``: watch every scenario of a run in the browser.

- ``catalog``: the runs and scenarios under the folders given, the agent's attempts from
  ``trace.jsonl``, variants and files;
- ``scene``: one played scenario as the page animates and charts it, from ``replay.json``
  (plus the record's values and the judge's findings where the folder has them);
- ``app``: the Starlette app (``create_app``, ``serve`` on loopback) and ``static/`` its page;
- ``static_site``: the same page written as files (``scenweave view --static OUT``).
"""

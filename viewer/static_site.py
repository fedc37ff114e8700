"""``scenweave view --static OUT``: the same page as a folder of files to share, opened from
disk (``file://``) or any plain web server, with no server of ours behind it.

Browsers do not let a ``file://`` page fetch JSON, so each answer of the API is written as a
small script that hands its data to the page (``SW.put(name, data)``): ``data/runs.js`` and
one ``data/sNNNN.js`` per scenario (and per variant) with its files' text inside.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from scenweave.viewer import catalog
from scenweave.viewer.app import INDEX_NAME, STATIC_DIR, check_assets

#: the line of index.html where the static site's data index is put
STATIC_MARK = "<!-- static data -->"


def write_static_site(paths: list[Path], out: Path) -> dict[str, int]:
    """Write the site into ``out`` (made if needed; earlier ``data/`` replaced); counts."""
    check_assets()
    runs = catalog.find_runs(paths)
    out.mkdir(parents=True, exist_ok=True)
    data = out / "data"
    if data.exists():
        shutil.rmtree(data)
    data.mkdir()
    shutil.copytree(STATIC_DIR, out / "static", dirs_exist_ok=True)
    listing = catalog.run_list(runs)
    ids: dict[str, str] = {}
    for key in _scenario_keys(runs, listing):
        detail = catalog.scenario_detail(runs, key)
        detail["file_texts"] = {f["name"]: catalog.file_text(runs, key, f["name"])
                                for f in detail["files"]}
        ids[key] = f"s{len(ids):04d}"
        _write_script(data / f"{ids[key]}.js", f"scenario:{key}", detail)
    _write_script(data / "runs.js", "runs", listing)
    _write_script(data / "index.js", "static", {"ids": ids})
    page = (STATIC_DIR / INDEX_NAME).read_text(encoding="utf-8")
    page = page.replace(STATIC_MARK, '<script src="data/index.js"></script>'
                        '<script src="data/runs.js"></script>')
    (out / INDEX_NAME).write_text(page, encoding="utf-8")
    for path in out.rglob("*"):
        path.chmod(0o755 if path.is_dir() else 0o644)
    return {"runs": len(listing), "scenarios": len(ids)}


def _scenario_keys(runs: dict[str, catalog.Run], listing: list[dict]) -> list[str]:
    keys = []
    for run in listing:
        for row in run["scenarios"]:
            keys.append(row["key"])
            folder = catalog.scenario_folder(runs, row["key"])
            keys += [v["key"] for v in catalog.variants(folder, row["key"])]
            if row.get("in_situ") and row["in_situ"]["key"] != row["key"]:
                keys.append(row["in_situ"]["key"])
    return keys


def _write_script(path: Path, name: str, data: object) -> None:
    # "</" cannot close a script element from inside a JSON string when written as "<\/"
    body = catalog.as_json(data).replace("</", "<\\/")
    path.write_text(f"SW.put({json.dumps(name)},{body});\n", encoding="utf-8")

"""Pick the reference script for a manoeuvre: keyword, then tag table, then semantic similarity.

Thesis Table 5.4, with a real embedding model for the last level:
1. keyword: the lower-cased ``maneuver_class`` is a substring of exactly one script name
   (``CINF`` -> ``gen_hw_cinf.py``);
2. tag: the manoeuvre registry names each tag's script (``BR_BK`` has tag ``brake``);
3. semantic: cosine similarity between the query and the scripts' docstrings, embedded with
   all-MiniLM-L6-v2 (see ``corpus.embedding``; the docstring embeddings are cached).
"""

from __future__ import annotations

import ast
import hashlib
import importlib
import importlib.util
import io
import os
import re
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import ModuleType

import numpy as np

from scenweave import maneuvers
from scenweave.corpus.errors import CorpusError
from scenweave.errors import ParamsError
from scenweave.files import write_bytes_atomic
from scenweave.schemas.params import Params

CORPUS_DIR = Path(__file__).resolve().parent

def class_tags() -> dict[str, str]:
    """maneuver_class -> maneuver_tag (docs/params.md), for queries that give only a code."""
    return {m.code: m.tag for m in maneuvers.maneuvers()}


def tag_scripts() -> dict[str, Path]:
    """maneuver_tag -> reference script (docs/params.md, "Corpus tags"); the first class of
    a tag by code names it (``BR_BK`` shares ``brake`` with ``BRAKE``)."""
    found: dict[str, Path] = {}
    for maneuver in maneuvers.maneuvers():
        found.setdefault(maneuver.tag, script_path(maneuver))
    return found


def script_path(maneuver: maneuvers.Maneuver) -> Path:
    """A class's reference script: a name in the corpus folder, or a plugin's own file."""
    path = Path(maneuver.script)
    return path if path.is_absolute() else CORPUS_DIR / path


@dataclass(frozen=True)
class Retrieval:
    """The chosen reference script, its source, how it was found and how sure that is (0..1)."""

    script_path: Path
    source: str
    method: str
    score: float


def list_scripts() -> list[Path]:
    """The reference scripts of the corpus, sorted by name."""
    return list(_scripts())


def _scripts() -> tuple[Path, ...]:
    """The corpus folder's scripts, and those of plugin classes kept elsewhere."""
    added = {script_path(m) for m in maneuvers.maneuvers()}
    return tuple(sorted({*_corpus_scripts(), *added}, key=lambda path: path.name))


@cache
def _corpus_scripts() -> tuple[Path, ...]:
    return tuple(sorted(CORPUS_DIR.glob("gen_*.py")))


def retrieve(params_or_query: Params | str) -> Retrieval:
    """The reference script for a params dict or for a class code, tag or free-text query."""
    tags = class_tags()
    if isinstance(params_or_query, str):
        query = params_or_query.strip()
        code = query if query.upper() in tags else ""  # free text is never a keyword
        tag = tags.get(query.upper(), query)
    else:
        code = str(params_or_query.get("maneuver_class") or "")
        tag = str(params_or_query.get("maneuver_tag") or tags.get(code.upper(), ""))
        query = _params_query(params_or_query)
    found = _by_keyword(code) or _by_tag(tag)
    if found is not None:
        return found
    return retrieve_semantic(query)


def generate(params: Params, out_path: str | os.PathLike[str]) -> Path:
    """Run the retrieved reference script in-process: the deterministic (``--no-llm``) path.

    Params the script cannot use raise ``ParamsError`` naming the scenario, script and key.
    """
    script = retrieve(params).script_path
    module = _load_script(script)
    try:
        return Path(module.generate(dict(params), out_path))
    except KeyError as err:
        raise ParamsError(f"{_who(params, script)}: missing params key {err.args[0]!r}") from err
    except (TypeError, ValueError) as err:
        raise ParamsError(f"{_who(params, script)}: {err}") from err


def _load_script(script: Path) -> ModuleType:
    if script.parent == CORPUS_DIR:
        return importlib.import_module(f"scenweave.corpus.{script.stem}")
    name = f"scenweave_reference_{script.stem}"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, script)
        if spec is None or spec.loader is None:
            raise CorpusError(f"reference script {script} cannot be loaded")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[name] = module
    return sys.modules[name]


def _who(params: Params, script: Path) -> str:
    return f"scenario {params.get('scenario_id', '?')} ({script.name})"


def _read(path: Path, method: str, score: float) -> Retrieval:
    return Retrieval(path, _source(path), method, score)


@cache
def _source(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _by_keyword(code: str) -> Retrieval | None:
    """The class's own script when the registry knows the code (a plugin class coded ``STOP``
    gets its script, not ``gen_ur_stop_at_tfl_red.py``); else a script whose name holds it."""
    maneuver = maneuvers.find(code) if code else None
    if maneuver is not None:  # named after its class (thesis: keyword), or shared by its tag
        path = script_path(maneuver)
        return _read(path, "keyword" if code.lower() in path.stem else "tag", 1.0)
    key = code.lower()
    if not key or " " in key:
        return None
    hits = [path for path in _scripts() if key in path.stem]
    if len(hits) > 1:  # several names contain it: only a whole name part is unambiguous
        hits = [path for path in hits if key in path.stem.split("_")]
    return _read(hits[0], "keyword", 1.0) if len(hits) == 1 else None


def _by_tag(tag: str) -> Retrieval | None:
    path = tag_scripts().get(tag.lower())
    return _read(path, "tag", 1.0) if path else None


def _params_query(params: Params) -> str:
    """Thesis query form: "{maneuver} speed {v} m/s distance {d} m"."""
    maneuver = (params.get("description") or params.get("maneuver_tag") or
                params.get("maneuver_class") or "driving")
    speed = params.get("ego_speed_ms") or 0.0
    distance = params.get("npc_distance_m") or params.get("lead_distance_m") or 0.0
    return f"{str(maneuver).replace('_', ' ')} speed {speed:.1f} m/s distance {distance:.1f} m"


def docstring(path: Path) -> str:
    """The module docstring of a reference script: the text semantic retrieval compares with."""
    return ast.get_docstring(ast.parse(_source(path))) or path.stem


def prose(text: str) -> str:
    """``text`` without class codes and params identifiers, which only blur a sentence embedding.

    Docstrings name params keys (``npc_speed_ms``) for the LLM's sake; to the embedding model
    they are noise shared by all scripts (held-out R@1 7/16 -> 10/16 without them).
    """
    text = re.sub(r"\([A-Z0-9_, ]+\)", " ", text)
    text = re.sub(r"\b\w*_\w*\b", " ", text)
    return " ".join(text.split())


def retrieve_semantic(query: str) -> Retrieval:
    """The script whose docstring is most similar to ``query`` (cosine, all-MiniLM-L6-v2)."""
    from scenweave.corpus.embedding import encoder

    scripts, matrix = _docstring_embeddings()
    scores = matrix @ encoder().encode([query])[0]
    best = int(np.argmax(scores))
    return _read(scripts[best], "semantic", float(scores[best]))


@cache
def _docstring_embeddings() -> tuple[list[Path], np.ndarray]:
    scripts = list_scripts()
    if not scripts:
        raise CorpusError(f"no reference scripts gen_*.py in {CORPUS_DIR}")
    texts = [prose(docstring(path)) for path in scripts]
    cache_file = _cache_dir() / f"corpus-docstrings-{_digest(texts)}.npy"
    if cache_file.exists():
        return scripts, np.load(cache_file)
    from scenweave.corpus.embedding import encoder

    matrix = encoder().encode(texts)
    _save_atomically(cache_file, matrix)
    return scripts, matrix


def _cache_dir() -> Path:
    home = os.environ.get("SCENWEAVE_HOME") or Path.home() / ".scenweave"
    return Path(home) / "cache"


def _digest(texts: list[str]) -> str:
    from scenweave.corpus.embedding import model_dir

    weights = model_dir() / "model.safetensors"
    key = "\0".join([str(weights.stat().st_size), *texts])
    return hashlib.sha256(key.encode("utf-8")).hexdigest()[:16]


def _save_atomically(path: Path, matrix: np.ndarray) -> None:
    buffer = io.BytesIO()
    np.save(buffer, matrix)
    try:
        write_bytes_atomic(path, buffer.getvalue())
    except OSError:
        return  # a read-only home only costs recomputing the 16 embeddings next time

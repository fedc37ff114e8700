#!/usr/bin/env bash
# Sets the machine up (quick when already done), checks style and types, runs the whole test
# suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/ruff check .
.venv/bin/python scripts/typecheck.py
exec .venv/bin/pytest "$@"

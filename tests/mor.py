"""The benchmark models of ../shared/data/mor (SLICOT collection) for tests and benchmarks.

The project never depends on them at run time: tests skip cleanly when the folder is absent
(:func:`load_mor`), benchmarks stop with a message (:func:`read_mor`).
"""

from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse

from linflex import LinearSystem

MOR_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "mor"


def read_mor(name: str) -> LinearSystem:
    """A model by file name (``"iss1R"`` or ``"iss1R.mat"``); FileNotFoundError when absent.

    The files store some matrices sparse and some as integers (see the folder's README); all
    become dense float64. None of the models has a non-zero D.
    """
    path = MOR_DIR / (name if name.endswith(".mat") else f"{name}.mat")
    if not path.exists():
        raise FileNotFoundError(f"benchmark model {path} not available (../shared/data/mor is absent)")
    data = scipy.io.loadmat(path)

    def dense(matrix):
        return np.asarray(matrix.todense() if scipy.sparse.issparse(matrix) else matrix, dtype=float)

    return LinearSystem(dense(data["A"]), dense(data["B"]), dense(data["C"]))


def load_mor(name: str) -> LinearSystem:
    """:func:`read_mor` for tests: a clean skip when the shared folder is absent."""
    import pytest

    try:
        return read_mor(name)
    except FileNotFoundError as err:
        pytest.skip(str(err))

"""The benchmark models of ``tests/data/mor`` (SLICOT collection) for tests and benchmarks.

The files ship with the project (provenance and licence in the folder's README); their bytes are
pinned by ``SHA256SUMS``, checked on every load.
"""

import hashlib
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse

from linflex import LinearSystem

MOR_DIR = Path(__file__).resolve().parent / "data" / "mor"


def _checksums() -> dict[str, str]:
    sums = {}
    for line in (MOR_DIR / "SHA256SUMS").read_text().splitlines():
        if line.strip():
            digest, name = line.split()
            sums[name.lstrip("*")] = digest
    return sums


def load_mor(name: str, *, sparse: bool = False) -> LinearSystem:
    """A model by file name (``"iss1R"`` or ``"iss1R.mat"``) as a float64 LinearSystem.

    The files store some matrices sparse and some as integers (see the folder's README); all
    become float64, dense, except ``A`` with ``sparse=True`` (kept as ``scipy.sparse``). None of the models has a non-zero D. Raises ValueError when the file's
    bytes differ from ``SHA256SUMS``.
    """
    file = name if name.endswith(".mat") else f"{name}.mat"
    path = MOR_DIR / file
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    if digest != _checksums()[file]:
        raise ValueError(f"{path}: SHA-256 {digest} differs from SHA256SUMS")
    data = scipy.io.loadmat(path)

    def dense(matrix):
        return np.asarray(matrix.todense() if scipy.sparse.issparse(matrix) else matrix, dtype=float)

    A = scipy.sparse.csr_matrix(data["A"], dtype=float) if sparse else dense(data["A"])
    return LinearSystem(A, dense(data["B"]), dense(data["C"]))

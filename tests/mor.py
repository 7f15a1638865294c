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


def sparse_chain(n: int, stiffness: float = 1e3, damping: float = 1e-3):
    """A fixed-fixed chain of ``n`` unit masses [kg] joined by springs of ``stiffness`` [N/m] with
    Rayleigh damping ``damping * K + 2 damping I`` [N s/m], in first-order form ``x = (q, q')``:
    ``(A, B, C)`` with a sparse banded ``A`` (``scipy.sparse`` CSR, 2n states, no block-diagonal
    structure), a force on the middle mass and the displacement of a mass two further on.
    Natural frequencies ``2 sqrt(stiffness) sin(k pi / (2 (n + 1)))`` [rad/s]."""
    K = scipy.sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) * stiffness
    Dm = damping * K + 2 * damping * scipy.sparse.identity(n)
    A = scipy.sparse.bmat([[None, scipy.sparse.identity(n)], [-K, -Dm]], format="csr")
    B = np.zeros((2 * n, 1))
    B[n + n // 2, 0] = 1.0
    C = np.zeros((1, 2 * n))
    C[0, n // 2 + 2] = 1.0
    return A, B, C

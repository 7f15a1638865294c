"""Small numerical helpers shared by the layers (private: imported as ``linflex.system._numerics``)."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray


def schur_eigenvalues(S: NDArray[np.float64]) -> NDArray[np.complex128]:
    """Eigenvalues of a real quasi-triangular Schur form, in the order of its diagonal blocks.

    A 2x2 block ``[[a, b], [c, d]]`` (non-zero subdiagonal ``c``) gives
    ``(a + d)/2 +- sqrt((a - d)^2/4 + b c)``, the ``+`` root first; all blocks at once.
    """
    ev = np.diag(S).astype(complex)
    i0 = np.flatnonzero(np.diag(S, -1) != 0.0)
    if i0.size:
        a, b, c, d = S[i0, i0], S[i0, i0 + 1], S[i0 + 1, i0], S[i0 + 1, i0 + 1]
        mean = 0.5 * (a + d)
        root = np.sqrt((0.25 * (a - d) ** 2 + b * c).astype(complex))
        ev[i0], ev[i0 + 1] = mean + root, mean - root
    return ev


def diagonal_balance(A, B, C):
    """``(A_bal, B_bal, C_bal, scale)``: the exact diagonal similarity (powers of 2) of LAPACK's
    balancing without permutation, ``A_bal = D^-1 A D``, ``B_bal = D^-1 B``, ``C_bal = C D``;
    the transfer function ``C (sI - A)^-1 B`` is unchanged."""
    Ab, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    return Ab, B / scale[:, None], C * scale[None, :], scale

"""Low-rank factors of the gramians of large sparse stable systems by the ADI iteration.

``A P + P A^T + B B^T = 0`` with ``A`` sparse and stable, ``B`` of few columns: the low-rank ADI
iteration (J.-R. Li and J. White, SIAM J. Matrix Anal. Appl. 24 (2002); T. Penzl, SIAM J. Sci.
Comput. 21 (2000)) in its residual form (P. Benner, P. Kuerschner and J. Saak, Numer. Algorithms 62
(2013)): with ``W_0 = B`` and shifts ``p_i`` in the open left half-plane,

    V_i = (A + p_i I)^-1 W_(i-1),   W_i = W_(i-1) - 2 Re(p_i) V_i,   Z_i = [Z_(i-1), sqrt(-2 Re p_i) V_i]

gives ``P ~ Z Z^H`` whose residual is exactly ``A Z Z^H + Z Z^H A^T + B B^T = W W^H``, so the
relative residual ``||W^H W||_2 / ||B^T B||_2`` is known at every step for the cost of a small
product, and the iteration stops on it. Each step is one sparse LU of ``A + p I`` (SuperLU,
O(nnz) for the banded or tree-like patterns of structural models; a shift used again reuses its
factors). A complex shift is followed by its conjugate, so that ``Z Z^H`` is real: its real
factor is ``[Re Z, Im Z]``, compressed by a QR and an SVD to the columns above the residual's
level.

Shifts: the eigenvalues of ``A`` projected on an extended Krylov space of ``B`` (``B``,
``A^-1 B``, ``A B``, ``A^-2 B``) to start, then after every cycle those of ``A`` projected on the
columns that cycle added ("projection shifts", Benner, Kuerschner and Saak, Electron. Trans.
Numer. Anal. 43 (2014)), mirrored into the left half-plane where a projection puts one right of
the axis.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import NDArray

from linflex import ConvergenceError

__all__ = ["AdiFactor", "adi_gramian_factor"]

#: Shifts kept per cycle (the projection gives as many as the columns of a cycle).
MAX_SHIFTS = 48
#: Columns of the factor (the newest) whose span gives the next cycle's shifts.
PROJECTION_COLUMNS = 120


@dataclass(frozen=True)
class AdiFactor:
    """A low-rank factor ``Z`` of a gramian, ``P ~ Z Z^T``.

    Attributes
    ----------
    Z : ndarray, shape (n, k)
        Real factor [state units per input unit s^1/2]: ``k`` is the steps times the inputs.
    residual : float
        Relative residual ``||A Z Z^T + Z Z^T A^T + B B^T||_2 / ||B B^T||_2`` [-] (exact: the
        iteration's ``||W^T W|| / ||B^T B||``).
    iterations : int
        ADI steps taken (sparse solves).
    factorizations : int
        Sparse LU factorizations (distinct shifts).
    seconds : float
        Wall time [s].
    """

    Z: NDArray[np.float64]
    residual: float
    iterations: int
    factorizations: int
    seconds: float


def _mirrored(values: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """Shifts from Ritz values: in the open left half-plane, one of each conjugate pair (the one
    of positive imaginary part stands for both), the largest first."""
    v = -np.abs(values.real) + 1j * values.imag
    v = v[np.abs(v.real) > 0]
    v = v[v.imag >= 0]
    v = np.where(np.abs(v.imag) > 1e-14 * np.abs(v), v, v.real)
    return v[np.argsort(-np.abs(v))][:MAX_SHIFTS]


def _projected(A, Q: NDArray) -> NDArray[np.complex128]:
    """Eigenvalues of ``A`` projected on the span of the real ``Q`` (orthonormalized here)."""
    Q = scipy.linalg.orth(Q)
    if Q.shape[1] == 0:
        return np.zeros(0, complex)
    return scipy.linalg.eigvals(Q.T @ (A @ Q))


def adi_gramian_factor(A, B: NDArray, *, rtol: float = 1e-10, max_iterations: int = 2000) -> AdiFactor:
    """Low-rank factor of the controllability gramian of ``(A, B)``: ``A P + P A^T + B B^T = 0``.

    Parameters
    ----------
    A : scipy.sparse matrix, shape (n, n)
        A stable state matrix [1/s].
    B : ndarray, shape (n, m)
        Input matrix [state units/s per input unit].
    rtol : float
        Relative residual [-] at which the iteration stops.
    max_iterations : int
        ADI steps at most.

    Returns
    -------
    AdiFactor

    Raises
    ------
    ConvergenceError
        When the residual is not below ``rtol`` after ``max_iterations`` steps or stops
        decreasing: ``A`` has eigenvalues on or right of the imaginary axis (a rigid-body mode),
        or modes too lightly damped for the steps allowed.
    """
    t0 = time.perf_counter()
    A = scipy.sparse.csc_matrix(A, dtype=float)
    B = np.asarray(B, dtype=float)
    n, m = B.shape
    if m == 0 or n == 0:
        return AdiFactor(np.zeros((n, 0)), 0.0, 0, 0, time.perf_counter() - t0)
    eye = scipy.sparse.identity(n, format="csc")
    base = float(np.linalg.norm(B.T @ B, 2))
    if base == 0.0:
        return AdiFactor(np.zeros((n, 0)), 0.0, 0, 0, time.perf_counter() - t0)
    try:
        lu0 = scipy.sparse.linalg.splu(A)
    except RuntimeError as err:
        raise ConvergenceError("ADI: A is singular (a rigid-body mode): the gramian does not exist") from err
    K = [B, lu0.solve(B), A @ B, lu0.solve(lu0.solve(B))]
    shifts = _mirrored(_projected(A, np.hstack(K)))
    factors: dict[complex, object] = {}
    W = B.copy()
    blocks: list[NDArray] = []
    residual, iterations, best, stalled = 1.0, 0, np.inf, 0
    while residual > rtol:
        if shifts.size == 0:
            raise ConvergenceError("ADI: no shift in the left half-plane (is A stable?)")
        for p in shifts:
            if p not in factors:
                try:
                    factors[p] = scipy.sparse.linalg.splu((A + p * eye).tocsc() if p.imag else
                                                          (A + p.real * eye).tocsc())
                except RuntimeError as err:  # A + p I singular: an eigenvalue -p right of the axis
                    raise ConvergenceError(f"ADI: A has an eigenvalue at {-p:.6g}, right of the imaginary axis "
                                           "(A is not stable)") from err
            if p.imag:
                # the pair p, conj(p) in real arithmetic (Benner, Kuerschner and Saak 2013): one
                # complex solve, two real columns per input, W real again
                V = factors[p].solve(W.astype(complex))
                d = p.real / p.imag
                Vr = V.real + d * V.imag
                W = W - 4.0 * p.real * Vr
                g = 2.0 * np.sqrt(-p.real)
                blocks += [g * Vr, (g * np.sqrt(d * d + 1.0)) * V.imag]
                iterations += 2
            else:
                p = p.real
                V = factors[p].solve(W)
                W = W - 2.0 * p * V
                blocks.append(np.sqrt(-2.0 * p) * V)
                iterations += 1
            residual = float(np.linalg.norm(W.T @ W, 2)) / base
            if residual <= rtol:
                break
            if iterations >= max_iterations:
                raise ConvergenceError(
                    f"ADI: relative residual {residual:.3g} after {iterations} steps (rtol {rtol:g}): A may have "
                    "eigenvalues on or near the imaginary axis (rigid-body or undamped modes)")
        if residual > rtol:
            if residual >= 0.99 * best:
                stalled += 1
                if stalled >= 5:
                    raise ConvergenceError(
                        f"ADI: the residual stopped decreasing at {residual:.3g} after {iterations} steps: A has "
                        "eigenvalues on or right of the imaginary axis (split rigid-body modes off first)")
            else:
                stalled = 0
            best = min(best, residual)
            recent = np.hstack(blocks[-max(1, PROJECTION_COLUMNS // m):])
            shifts = _mirrored(_projected(A, recent))
    return AdiFactor(np.hstack(blocks), residual, iterations, len(factors), time.perf_counter() - t0)


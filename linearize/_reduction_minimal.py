"""Minimal realization by orthogonal staircase forms, with the rank decisions reported."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError, as_linear_system

__all__ = ["MinimalRealization", "minimal_realization"]


@dataclass(frozen=True)
class MinimalRealization:
    """Result of :func:`minimal_realization`.

    Attributes
    ----------
    sys : LinearSystem
        The minimal system; states ``xm0, xm1, ...``.
    order : int
        Its number of states.
    n_uncontrollable, n_unobservable : int
        States removed in the controllability step, then in the observability step.
    tol : float
        Absolute threshold on the singular values of the staircase blocks; a block singular
        value at or below it counts as zero.
    smallest_kept, largest_discarded : float
        Over all rank decisions, the smallest singular value counted as non-zero and the largest
        counted as zero (0 when none was discarded or all were exactly zero). A wide gap between
        them, with ``tol`` inside it, means the order is well determined; a small gap means the
        system is close to one of lower order and the result depends on ``tol``.
    V, W : ndarray
        Orthonormal projection bases ``(n, order)``: ``x ~ V xm``, ``xm = W.T x`` (``W = V`` here,
        as both steps are orthogonal).
    seconds : float
        Wall time.
    """

    sys: LinearSystem
    order: int
    n_uncontrollable: int
    n_unobservable: int
    tol: float
    smallest_kept: float
    largest_discarded: float
    V: NDArray[np.float64]
    W: NDArray[np.float64]
    seconds: float


def minimal_realization(sys, tol: float | None = None) -> MinimalRealization:
    """Remove uncontrollable and unobservable states by orthogonal transformations.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system.
    tol : float, optional
        Absolute threshold on the singular values of the staircase blocks. Default
        ``n^2 * eps * max(||A||_F, ||B||_F, ||C||_F)`` (the default of SLICOT TB01PD), above the
        round-off that accumulates in the blocks.

    Returns
    -------
    MinimalRealization

    Raises
    ------
    ModelError
        If ``tol`` is negative or not finite.

    Notes
    -----
    Controllability staircase form (Van Dooren, "The generalized eigenstructure problem in linear
    system theory", IEEE TAC 26, 1981; SLICOT TB01PD): an SVD of ``B`` splits the state into its
    range and the rest; the block of ``A`` coupling the rest to the range is treated the same
    way, until a block has rank zero. The controllable states are the ones reached; the same on
    ``(A^T, C^T)`` of the controllable part removes the unobservable states. Orthogonal steps
    keep the rank decisions well conditioned; the gap of every decision is reported.
    Unlike a balanced truncation this works for any poles, including rigid-body modes.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> sys = LinearSystem([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 1.0]])
    >>> minimal_realization(sys).order
    1
    """
    t0 = time.perf_counter()
    sys = as_linear_system(sys, "sys")
    A, B, C = sys.A, sys.B, sys.C
    n = sys.n_states
    if tol is None:
        scale = max(np.linalg.norm(A), np.linalg.norm(B), np.linalg.norm(C), np.finfo(float).tiny)
        tol = max(n, 1) ** 2 * np.finfo(float).eps * scale
    else:
        try:
            tol = float(tol)
        except (TypeError, ValueError) as err:
            raise ModelError(f"tol must be a non-negative real number, got {tol!r}") from err
        if not np.isfinite(tol) or tol < 0:
            raise ModelError(f"tol must be a non-negative finite threshold, got {tol!r}")
    kept: list[float] = []
    dropped: list[float] = []
    Qc, nc = _staircase(A, B, tol, kept, dropped)
    Ac, Cc = Qc.T @ A @ Qc, C @ Qc
    Qo, no = _staircase(Ac.T, Cc.T, tol, kept, dropped)
    V = Qc @ Qo
    red = LinearSystem(
        V.T @ A @ V, V.T @ B, C @ V, sys.D, states=[f"xm{i}" for i in range(no)],
        inputs=sys.inputs, outputs=sys.outputs,
    )
    V = np.ascontiguousarray(V)
    V.setflags(write=False)
    return MinimalRealization(
        sys=red, order=no, n_uncontrollable=n - nc, n_unobservable=nc - no, tol=float(tol),
        smallest_kept=float(min(kept)) if kept else 0.0, largest_discarded=float(max(dropped)) if dropped else 0.0,
        V=V, W=V, seconds=time.perf_counter() - t0,
    )


def _staircase(A, B, tol, kept, dropped) -> tuple[NDArray[np.float64], int]:
    """Orthonormal basis ``(n, k)`` of the controllable subspace of ``(A, B)`` and its dimension."""
    n = A.shape[0]
    Q = np.eye(n)
    At = np.array(A, dtype=float)
    k = 0
    block = B
    while k < n and block.size:
        U, s, _ = scipy.linalg.svd(block, full_matrices=True)
        r = int(np.sum(s > tol))
        if r < s.size:
            dropped.append(s[r])
        if r:
            kept.append(s[r - 1])
        if r == 0:
            break
        Q[:, k:] = Q[:, k:] @ U
        At[k:, :] = U.T @ At[k:, :]
        At[:, k:] = At[:, k:] @ U
        block = At[k + r:, k:k + r]
        k += r
    return Q[:, :k], k

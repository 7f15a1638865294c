"""Roots of ``c + G(s)`` for a SISO system in a structured modal form, in O(n) per root and step.

The zeros of a loop (``c = 0``) and the closed-loop poles under a gain (``c = 1/k``) are the
roots of the polynomial ``P = (c + G) Q`` with ``Q(s) = prod_i (s - mu_i)`` over the poles. A
dense pencil costs O(n^3); with the modal form of :mod:`._modal_forms` (``G(s) = D + sum_i
r_i / (s - lambda_i)`` plus a small dense block) the Newton ratio of ``P`` is

    P'/P (s) = f'(s) / f(s) + sum_i 1 / (s - mu_i),     f = c + G,

O(n) per point, and the Aberth-Ehrlich iteration (Aberth, Math. Comp. 27, 1973; the method of
MPSolve) moves every root at once,

    s_j <- s_j - 1 / (P'/P (s_j) - sum_{l != j} 1 / (s_j - s_l)),

locally cubically convergent to simple roots, with no deflation. The iteration starts beside
the poles (the roots of a lightly damped flexible loop interlace them) and freezes a root when
its step falls below ``1e-12 |s_j|`` or ``|c + G(s_j)|`` is below its rounding bound; the roots that did not converge within the iteration
limit are not returned (the callers use these roots to place grid points, and a missing one
only leaves its notch to the grid's extremum refinement).

The number of roots is ``n - d`` with ``d`` the relative degree of ``c + G``: the index of the
first Markov parameter ``C A^(k-1) B`` that is not zero to rounding
(``|h_k| <= 1e3 n eps |C| |A|^(k-1) |B|`` counts as zero).
"""

from __future__ import annotations

import numpy as np
import scipy.spatial
from numpy.typing import NDArray

from ._modal_forms import _solve_or_inf
from ._spectrum import EPS

__all__ = ["modal_roots"]

#: Largest relative degree tried; beyond it no roots are returned.
MAX_RELATIVE_DEGREE = 8


def _relative_degree(A, b, c, d: float) -> int | None:
    """Index of the first non-zero Markov parameter of ``d + c (sI - A)^-1 b`` (0 for ``d != 0``)."""
    if d != 0:
        return 0
    n = A.shape[0]
    v, av, absA = b.copy(), np.abs(b), np.abs(A)
    for k in range(1, min(n, MAX_RELATIVE_DEGREE) + 1):
        h, bound = c @ v, np.abs(c) @ av
        if abs(h) > 1e3 * n * EPS * bound:
            return k
        v, av = A @ v, absA @ av
    return None


def _ratio(modal, channel, mu_extra: NDArray, shift: complex, z: NDArray):
    """``P'/P`` at the points ``z``: ``f'/f + sum_i 1/(z - mu_i)`` with ``f = shift + G``, and
    whether ``|f|`` is below its own rounding bound there, ``4 (n + 4) eps (|shift + d| +
    sum_i |r_i| / |z - lambda_i| + |C1| |(zI - T11)^-1 B1|)`` (the point is then a root as far as
    the arithmetic can tell)."""
    o, i = channel
    r = modal.K[:, o * modal.shape[1] + i]
    with np.errstate(all="ignore"):
        R = 1.0 / (z[:, None] - modal.lam[None, :])
        f = shift + modal.D[o, i] + R @ r
        size = np.abs(shift + modal.D[o, i]) + np.abs(R) @ np.abs(r)
        fp = -(R * R) @ r
        pole_sum = R.sum(axis=1)
        if modal.k:
            M = z[:, None, None] * np.eye(modal.k)[None] - modal.T11[None]
            rhs = np.broadcast_to(modal.B1[:, [i]], (len(z), modal.k, 1))
            try:
                X = np.linalg.solve(M, rhs)
                Y = np.linalg.solve(M, X)
            except np.linalg.LinAlgError:
                # a point on an eigenvalue of the block, or not finite: no step there (the caller
                # drops the point and, short of roots, takes its other path); the rest go on
                X = np.stack([_solve_or_inf(Mi, bi) for Mi, bi in zip(M, rhs)])
                Y = np.stack([_solve_or_inf(Mi, xi) for Mi, xi in zip(M, X)])
            f = f + (modal.C1[[o]][None] @ X)[:, 0, 0]
            size = size + (np.abs(modal.C1[[o]])[None] @ np.abs(X))[:, 0, 0]
            fp = fp - (modal.C1[[o]][None] @ Y)[:, 0, 0]
            pole_sum = pole_sum + (1.0 / (z[:, None] - mu_extra[None, :])).sum(axis=1)
        at_root = np.abs(f) <= 4 * (len(modal.lam) + modal.k + 4) * EPS * size
        return fp / f + pole_sum, at_root


def modal_roots(modal, sys, shift: complex = 0.0, channel: tuple[int, int] = (0, 0), *, start=None,
                max_iter: int = 60, chunk: int = 256) -> NDArray[np.complex128]:
    """The converged roots [1/s] of ``shift + G_oi(s)`` for the channel ``(o, i)`` of the
    system ``sys`` with the modal form ``modal`` (see the module docstring); ``start``: the
    first guesses (say the roots at a neighbouring gain), used when there is one per root.

    Returns an empty array when the relative degree exceeds ``MAX_RELATIVE_DEGREE``.
    """
    o, i = channel
    A = sys.A
    n = A.shape[0]
    d = _relative_degree(A, sys.B[:, i], sys.C[o], complex(shift + modal.D[o, i]))
    if d is None or n - d <= 0:
        return np.zeros(0, dtype=complex)
    N = n - d
    mu = np.asarray(modal.poles, dtype=complex)
    mu_extra = mu[len(modal.lam):]
    given = None if start is None else np.asarray(start, dtype=complex)
    # start beside the poles of smallest modulus (the d largest poles have no root beside them)
    start = mu[np.argsort(np.abs(mu), kind="stable")][:N]
    scale = np.maximum(np.abs(start), np.max(np.abs(mu), initial=1.0) * 1e-8)
    offset = 0.3 * np.maximum(np.abs(start.real), 1e-3 * scale)
    z = start + offset * np.exp(2j * np.pi * (np.arange(N) + 0.25) / max(N, 1))
    if given is not None and given.shape == (N,) and np.all(np.isfinite(given)):
        # distinct guesses: a repeated one (a double root) is nudged apart
        z = given + offset * 1e-3 * np.exp(2j * np.pi * (np.arange(N) + 0.25) / max(N, 1))
    active = np.ones(N, dtype=bool)
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        step = np.empty(idx.size, dtype=complex)
        at_root = np.empty(idx.size, dtype=bool)
        for a in range(0, idx.size, chunk):
            j = idx[a:a + chunk]
            with np.errstate(all="ignore"):
                diff = z[j][:, None] - z[None, :]
                diff[np.arange(j.size), j] = np.inf
                ratio, at_root[a:a + chunk] = _ratio(modal, channel, mu_extra, shift, z[j])
                step[a:a + chunk] = 1.0 / (ratio - (1.0 / diff).sum(axis=1))
        step[at_root] = 0.0
        ok = np.isfinite(step)
        z[idx[ok]] -= step[ok]
        done = ok & (np.abs(step) <= 1e-12 * np.abs(z[idx]))
        active[idx[done]] = False
        active[idx[~ok]] = False
        z[idx[~ok]] = np.nan
    keep = ~active & np.isfinite(z)
    return z[keep]


def closed_loop_poles(modal, sys) -> NDArray[np.complex128] | None:
    """All ``n`` poles [1/s] of the unit feedback loop ``1 / (1 + G)`` of a SISO system, the roots
    of ``1 + G`` by :func:`modal_roots` (O(n^2) after the modal form, no second eigenproblem),
    or None unless every root converged, the roots are distinct and their sum is the trace of
    ``A - b c / (1 + d)`` to ``1e3 n eps`` of the sum of their moduli (a missed or doubled root
    moves it by a root's size): the caller then takes a dense eigenproblem. A stability count
    needs every pole, so nothing less than the full set is returned."""
    n = sys.n_states
    d = float(sys.D[0, 0])
    if n == 0 or sys.shape != (1, 1) or 1.0 + d == 0:
        return None
    roots = modal_roots(modal, sys, 1.0)
    if roots.size != n or not np.all(np.isfinite(roots)):
        return None
    trace = float(np.trace(sys.A)) - float(sys.C[0] @ sys.B[:, 0]) / (1.0 + d)
    size = float(np.sum(np.abs(roots))) + abs(trace)
    if not abs(complex(np.sum(roots)) - trace) <= 1e3 * n * EPS * size:
        return None
    if n > 1:
        points = np.column_stack([roots.real, roots.imag])
        dist, _ = scipy.spatial.cKDTree(points).query(points, k=2)
        if not np.all(dist[:, 1] > 0):
            return None
    return roots

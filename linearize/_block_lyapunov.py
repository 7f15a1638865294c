"""Gramian factors of a block-diagonal (modal) Schur form in real arithmetic, O(n^2 m).

A modal model's stable part (``split_stable`` of a block-diagonal ``A``, or of a modal plant in
series with a small controller) has a real Schur form

::

    S = blockdiag(H, s_1, ..., s_N)

with ``H`` a small upper quasi-triangular block (``h`` states: the controller, blocks of real
eigenvalues) and every ``s_j`` a 1x1 block or a 2x2 block of a complex pair. Hammarling's
recursion (IMA J. Numer. Anal. 2, 1982) in real arithmetic with 1x1 and 2x2 pivots (the
method of SLICOT's SB03OT) gives the upper triangular ``R`` with ``S R R^T + R R^T S^T + B B^T = 0``:
partitioned from the bottom right with a pivot block ``S2`` (1x1 or 2x2)

::

    S = [ S1  s  ]   B = [ B1 ]   R = [ R1  r  ]
        [  0  S2 ]       [ B2 ]       [  0  R2 ]

    S2 R2 R2^T + R2 R2^T S2^T + B2 B2^T = 0          (R2 upper triangular, 1x1 or 2x2)
    S1 Y + Y S2^T = -(s R2 R2^T + B1 B2^T),   r = Y R2^-T
    recurse on S1 with B1 <- B1 - r R2^-1 B2          (still m columns)

On the modal part ``s = 0`` and ``S1`` is block diagonal, so the Sylvester equation splits into
independent 1x1 and 2x2 blocks, solved for all blocks at once: a pivot costs O(n m) and the
factor O(n^2 m), with no complex arithmetic and no QR compression of a complex factor (the
dense path of :mod:`linflex.linearize._balanced`: O(n^3)). ``H`` takes LAPACK ``dtrsyl``.
The small Hankel singular values keep their relative accuracy as in the dense recursion (no
gramian is formed).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = ["block_lyapunov_factors", "diagonal_blocks", "modal_extent"]

#: Largest leading quasi-triangular block ``H`` the recursion takes (it is solved by ``dtrsyl``
#: at every pivot, so its order enters the cost as O(n h^2)).
DENSE_PART_MAX = 64
#: Smallest ``det(P2) / (p11 p22)`` of a 2x2 pivot's gramian the recursion accepts (see
#: :func:`_pivot_factor`); below it :func:`block_lyapunov_factors` returns None.
PIVOT_DEFINITE = 1e-12


def modal_extent(S: NDArray[np.float64]) -> int:
    """The order ``h`` of the leading block ``H`` of a real quasi-triangular ``S`` beyond which
    ``S`` is block diagonal with 1x1 blocks and 2x2 blocks of complex pairs (``S[:h, h:] = 0``):
    ``S.shape[0]`` for a dense Schur form, 0 for a modal one."""
    n = S.shape[0]
    if n == 0:
        return 0
    sub = np.diag(S, -1) != 0.0                    # the first row of each 2x2 block
    pair = np.zeros(n, dtype=bool)                 # a state in a 2x2 block
    pair[:-1] |= sub
    pair[1:] |= sub
    upper = np.triu(S, 1) != 0.0
    i0 = np.flatnonzero(sub)
    upper[i0, i0 + 1] = False                      # a 2x2 block's own entry
    cols = np.flatnonzero(np.any(upper, axis=0))
    h = int(cols[-1]) + 1 if cols.size else 0
    if 0 < h < n and pair[h] and sub[h - 1]:       # a 2x2 block across the border
        h += 1
    return h


def block_lyapunov_factors(S: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64]):
    """Real factors ``(Zc, Zo)`` with ``S P + P S^T + B B^T = 0``, ``P = Zc Zc^T`` and
    ``S^T Q + Q S + C^T C = 0``, ``Q = Zo Zo^T``, for a stable real Schur form ``S`` of the
    modal shape of the module docstring; None when ``S`` has not that shape (its leading block
    above :data:`DENSE_PART_MAX`) or a pivot's gramian is not positive definite (a 2x2 block
    whose pair the inputs do not reach in round-off: the dense solvers take it).

    The recursion runs on ``S`` with its modal blocks reordered, the 1x1 ones first, then the
    2x2 ones (a block-diagonal matrix stays one under a permutation of its blocks), so the
    blocks of each kind are contiguous rows; for the observability equation on ``J S^T J``
    with ``J`` the reversal of ``H``'s states (upper quasi-triangular again). ``Zc`` and ``Zo``
    are the triangular factors with their rows put back in ``S``'s order.
    """
    n = S.shape[0]
    h = modal_extent(S)
    if h > DENSE_PART_MAX or n == 0:
        return None
    blocks = diagonal_blocks(S, h, n)
    ones = np.array([j for j, k in blocks if k == 1], dtype=np.intp)
    twos = np.array([j for j, k in blocks if k == 2], dtype=np.intp)
    body = np.r_[ones, np.stack([twos, twos + 1], axis=1).ravel()].astype(np.intp)
    factors = []
    for M, X, lead in ((S, B, np.arange(h)), (S.T, C.T, np.arange(h)[::-1])):
        idx = np.r_[lead, body]
        R = _factor(np.ascontiguousarray(M[np.ix_(idx, idx)]), h, ones.size, X[idx])
        if R is None:
            return None
        Z = np.empty_like(R)
        Z[idx] = R
        factors.append(Z)
    return factors[0], factors[1]


def diagonal_blocks(S, start: int, stop: int) -> list[tuple[int, int]]:
    """``(first index, order)`` of the 1x1 and 2x2 diagonal blocks of the quasi-triangular ``S``
    between ``start`` and ``stop`` (a 2x2 block has a non-zero subdiagonal entry)."""
    out, j = [], start
    while j < stop:
        k = 2 if j + 1 < stop and S[j + 1, j] != 0.0 else 1
        out.append((j, k))
        j += k
    return out


def _factor(S, h: int, n1: int, B) -> NDArray[np.float64] | None:
    """The recursion of the module docstring on ``S = blockdiag(H, d_1..d_n1, T_1..T_N)``:
    ``H = S[:h, :h]`` quasi-triangular, then ``n1`` 1x1 blocks, then 2x2 blocks."""
    n = S.shape[0]
    R = np.zeros((n, n), order="F")    # filled by columns
    Bw = np.array(B, dtype=float)
    t0 = h + n1                                        # the first 2x2 block
    pivots = diagonal_blocks(S, 0, h) + [(j, 1) for j in range(h, t0)] + [(j, 2) for j in range(t0, n, 2)]
    d1 = np.diag(S)[h:t0]
    tw = np.arange(t0, n, 2)
    T2 = np.stack([S[tw, tw], S[tw, tw + 1], S[tw + 1, tw], S[tw + 1, tw + 1]], axis=1).reshape(-1, 2, 2)
    TT = T2 @ T2
    for j, k in reversed(pivots):
        S2 = S[j:j + k, j:j + k]
        B2 = Bw[j:j + k]
        R2 = _pivot_factor(S2, B2)
        if R2 is None:
            return None
        R[j:j + k, j:j + k] = R2
        if j == 0 or not np.any(R2):
            continue
        rhs = -(Bw[:j] @ B2.T)
        if j <= h:        # a pivot of H (or the first modal one): S1 = H[:j, :j]
            if j < h:
                rhs -= S[:j, j:j + k] @ (R2 @ R2.T)
            Y = _sylvester_dense(S[:j, :j], S2, rhs)
        else:             # s = 0 and S1 = blockdiag(H, the modal blocks before j)
            Y = np.empty((j, k))
            if h:
                Y[:h] = _sylvester_dense(S[:h, :h], S2, rhs[:h])
            e1 = min(j, t0)
            Y[h:e1] = _solve_ones(d1[:e1 - h], S2, rhs[h:e1])
            if j > t0:
                i2 = (j - t0) // 2
                Y[t0:j] = _solve_twos(T2[:i2], TT[:i2], S2, rhs[t0:j].reshape(i2, 2, k)).reshape(-1, k)
        _update(R, Bw, j, k, Y, R2, B2)
    return R


def _update(R, Bw, j: int, k: int, Y, R2, B2) -> None:
    """``r = Y R2^-T`` into ``R[:j, j:j+k]`` and ``B1 <- B1 - r R2^-1 B2``."""
    inv = 1.0 / R2 if k == 1 else _adjugate_solve(R2[None], np.eye(2)[None])[0]
    r = Y @ inv.T
    R[:j, j:j + k] = r
    Bw[:j] -= r @ (inv @ B2)


def _pivot_factor(S2, B2) -> NDArray[np.float64] | None:
    """Upper triangular ``R2`` with ``S2 R2 R2^T + R2 R2^T S2^T + B2 B2^T = 0`` (1x1 or 2x2
    stable ``S2``); zeros where ``B2 = 0``; None where a 2x2 gramian is not positive definite
    in floating point."""
    if not np.any(B2):
        return np.zeros_like(S2)
    if S2.shape[0] == 1:
        return np.array([[np.sqrt(np.sum(B2 * B2) / (-2.0 * S2[0, 0]))]])
    (a, b), (c, d) = S2
    W = B2 @ B2.T
    w11, w12, w22 = W[0, 0], W[0, 1], W[1, 1]
    if a != 0.0 and d != 0.0:
        # rows 1 and 3 of the 3x3 system give p11 and p22 in terms of p12 (a Schur form's
        # 2x2 block has a = d = Re(lambda) < 0)
        p12 = (c * w11 / (2 * a) + b * w22 / (2 * d) - w12) / (a + d - b * c / a - b * c / d)
        p11 = -(w11 + 2 * b * p12) / (2 * a)
        p22 = -(w22 + 2 * c * p12) / (2 * d)
    else:
        K = np.array([[2 * a, 2 * b, 0.0], [c, a + d, b], [0.0, 2 * c, 2 * d]])
        p11, p12, p22 = np.linalg.solve(K, -np.array([w11, w12, w22]))
    det = p11 * p22 - p12 * p12
    # a complex pair any input reaches has a definite gramian; one whose determinant is within
    # 1e-12 of p11 p22 (the pair reached along one direction to rounding) would make R2^-1
    # amplify rounding by 1e6 or more: the dense solvers take such a model
    if not (p22 > 0 and det > PIVOT_DEFINITE * p11 * p22):
        return None
    r22 = np.sqrt(p22)
    return np.array([[np.sqrt(det / p22), p12 / r22], [0.0, r22]])


def _sylvester_dense(H, S2, rhs):
    """``Y`` with ``H Y + Y S2^T = rhs`` (``H`` upper quasi-triangular: LAPACK ``dtrsyl``)."""
    Y, scale, info = scipy.linalg.lapack.dtrsyl(H, S2, rhs, tranb="T", isgn=1)
    if info < 0 or not scale > 0:
        return scipy.linalg.solve_sylvester(H, S2.T, rhs)
    return Y / scale


def _solve_ones(d, S2, rhs):
    """``y_i (d_i I + S2^T) = rhs_i`` for all 1x1 blocks ``d_i`` at once (rows of ``rhs``)."""
    if S2.shape[0] == 1:
        return rhs / (d[:, None] + S2[0, 0])
    # y_i^T = (d_i I + S2)^-1 rhs_i^T
    M = d[:, None, None] * np.eye(2) + S2
    return _adjugate_solve(M, rhs[:, :, None])[:, :, 0]


#: The signs of a 2x2 adjugate: ``adj(M) = SIGNS * M[::-1, ::-1].T``.
_SIGNS = np.array([[1.0, -1.0], [-1.0, 1.0]])


def _adjugate_solve(M, rhs):
    """``M_i^-1 rhs_i`` for a stack of 2x2 matrices ``M`` (N, 2, 2) by their adjugates (``rhs``:
    (N, 2, k))."""
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    adj = M[:, ::-1, ::-1].transpose(0, 2, 1) * _SIGNS
    return (adj @ rhs) / det[:, None, None]


def _solve_twos(T2, TT, S2, rhs):
    """``T_i Y_i + Y_i S2^T = rhs_i`` for all 2x2 blocks ``T_i`` at once (``T2``: (N, 2, 2),
    ``TT``: their squares, ``rhs``: (N, 2, k)).

    For ``k = 2`` with ``S2 = [[a, b], [c, d]]`` the columns of ``Y`` solve ``(T + a) y1 + b y2
    = r1``, ``c y1 + (T + d) y2 = r2``; eliminating one column (``T + a`` and ``T + d``
    commute), ``M Y = T R + R K`` with ``M = (T + a)(T + d) - b c = T^2 + (a + d) T +
    (a d - b c)`` and ``K = [[d, -c], [-b, a]]``; ``M`` is singular exactly when the Sylvester
    equation is. ``k = 1``: ``(T + a) y = r``. Both by the 2x2 adjugate, batched over the
    blocks."""
    if S2.shape[0] == 1:
        M = T2 + S2[0, 0] * np.eye(2)
        rhs_m = rhs
    else:
        (a, b), (c, d) = S2
        M = TT + (a + d) * T2 + (a * d - b * c) * np.eye(2)
        rhs_m = T2 @ rhs + rhs @ np.array([[d, -c], [-b, a]])
    return _adjugate_solve(M, rhs_m)

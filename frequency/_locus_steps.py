"""Step geometry of the root locus: branch prediction, matching and the displacement test."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment


def _match(prev: NDArray, new: NDArray) -> NDArray:
    """``new`` reordered to follow ``prev`` by minimum total displacement (linear assignment).

    When the nearest new root of every previous root (a k-d tree, O(n log n)) is a different
    one, that is the assignment: the sum of the row minima bounds every assignment's total from
    below. Otherwise, above 200 roots, the assignment among each root's 8 nearest (a sparse
    bipartite matching of least weight, the weights shifted by a constant so that a zero
    distance stays an edge): the optimum whenever it uses those edges only, as it does for the
    steps the displacement test accepts (each root moves less than its spacing); else, and when
    that has no full matching, the dense O(n^3) linear assignment."""
    import scipy.sparse
    import scipy.sparse.csgraph
    import scipy.spatial

    out = np.empty_like(new)
    n = prev.size
    if new.size == n and n > 8 and np.all(np.isfinite(prev)) and np.all(np.isfinite(new)):
        tree = scipy.spatial.cKDTree(np.column_stack([new.real, new.imag]))
        dist, c = tree.query(np.column_stack([prev.real, prev.imag]), k=8)
        if np.unique(c[:, 0]).size == n:
            out[:] = new[c[:, 0]]
            return out
    if new.size == n and n > 200 and np.all(np.isfinite(prev)) and np.all(np.isfinite(new)):
        weight = dist + (float(np.max(dist)) + 1.0)
        graph = scipy.sparse.csr_matrix((weight.ravel(), c.ravel(), np.arange(0, 8 * n + 1, 8)), shape=(n, n))
        try:
            _, col = scipy.sparse.csgraph.min_weight_full_bipartite_matching(graph)
            out[:] = new[col]
            return out
        except ValueError:
            pass
    cost = np.abs(prev[:, None] - new[None, :])
    r, c = linear_sum_assignment(cost)
    out[r] = new[c]
    return out


def _nearest(s: NDArray, same: float, rows: NDArray | None = None):
    """Distance from each root (or from ``s[rows]``) to its nearest other root, and to its
    nearest other root farther than ``same``; brute force, O(n^2) with no tree to build."""
    sr = s if rows is None else s[rows]
    dx = np.subtract.outer(sr.real, s.real)
    dy = np.subtract.outer(sr.imag, s.imag)
    dx *= dx
    dy *= dy
    dx += dy
    if rows is None:
        np.fill_diagonal(dx, np.inf)
    else:
        dx[np.arange(len(sr)), rows] = np.inf
    nearest = np.sqrt(np.min(dx, axis=1))
    dx[dx <= same * same] = np.inf
    return nearest, np.sqrt(np.min(dx, axis=1))


class _Displacement:
    """Largest root movement relative to the distance to the nearest other distinct root.

    Roots that coincide to working accuracy (repeated roots, e.g. identical axes of a MIMO loop)
    are not each other's neighbours: exchanging them changes nothing, and counting their zero
    spacing would stall the gain steps. The spacing of the previous roots is computed once and
    reused by every trial step from them."""

    def __init__(self, s_ref: float) -> None:
        self.s_ref = s_ref
        self._of = None
        self._local = None

    def local(self, prev: NDArray, spacing: NDArray | None = None) -> NDArray:
        """Local spacing of the roots ``prev`` [1/s] (from ``spacing`` when the solver gave it),
        floored at their modulus plus ``s_ref``; kept for the last ``prev``."""
        if self._of is prev:
            return self._local
        n = len(prev)
        if spacing is None:
            if n > 1:
                same = 1e-6 * max(1.0, float(np.max(np.abs(prev))))
                spacing = _nearest(prev, same)[1]
            else:
                spacing = np.full(n, np.inf)
        self._of = prev
        self._local = np.minimum(spacing, np.abs(prev) + self.s_ref) + self.s_ref
        return self._local

    def __call__(self, prev: NDArray, new: NDArray, exempt: NDArray | None = None) -> float:
        if len(prev) == 0:
            return 0.0
        d = np.abs(new - prev) / self.local(prev)
        if exempt is not None:
            d[exempt] = 0.0
        return float(np.max(d))


def _predict(accepted: list, k: float) -> NDArray:
    """Roots at gain ``k`` extrapolated from the last accepted ``(gain, roots, derivatives)``.

    The derivatives (``[ds/dk, d2s/dk2]`` per root, from the Newton iterations, or ``None``)
    give a quintic Hermite polynomial through the last two points, whose error is ``O(h^6)``
    against ``O(h^4)`` of the cubic through values and tangents; with fewer data, a lower
    order: Taylor from the last point, or the secant."""
    k1, r1, d1 = accepted[-1]
    if len(accepted) < 2 or accepted[0][0] == k1:
        if d1 is None:
            return r1
        u = k - k1
        return r1 + u * (d1[:, 0] + (0.5 * u) * d1[:, 1])
    k0, r0, d0 = accepted[0]
    h = k1 - k0
    if d1 is None:
        return r1 + (r1 - r0) * ((k - k1) / h)
    if d0 is None:
        u = k - k1
        return r1 + d1[:, 0] * u + (r0 - r1 + d1[:, 0] * h) * (u * u / (h * h))
    # the six quintic Hermite basis functions of t = (k - k0)/h, as [1, t, ..., t^5] @ _HERMITE5,
    # scaled by the powers of h of their data, applied to the data in one product
    kk = np.asarray(k, dtype=float)
    t = ((kk.reshape(-1) - k0) / h)[:, None]
    H = np.cumprod(np.repeat(t, 5, axis=1), axis=1) @ _HERMITE5[1:]
    H += _HERMITE5[0]
    H *= np.array([1.0, 1.0, h, h, 0.5 * h * h, 0.5 * h * h])
    out = H @ np.stack([r0, r1, d0[:, 0], d1[:, 0], d0[:, 1], d1[:, 1]])
    return out.reshape(kk.shape[:-1] + (len(r1),) if kk.ndim else (len(r1),))


# rows: coefficients of 1, t, ..., t^5; columns: the basis functions of r0, r1, h d0, h d1,
# h^2/2 a0, h^2/2 a1 (value, tangent and second derivative at t = 0 and t = 1)
_HERMITE5 = np.array([
    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    [-10.0, 10.0, -6.0, -4.0, -3.0, 1.0],
    [15.0, -15.0, 8.0, 7.0, 3.0, -2.0],
    [-6.0, 6.0, -3.0, -3.0, -1.0, 1.0],
])



def _shortens(k_new: float, k_cur: float, k_try: float) -> bool:
    """Whether a substep to ``k_new`` shortens the step from ``k_cur`` to ``k_try`` by more
    than round-off (an exact landing on a breakaway gain must not propose it again)."""
    return min(k_cur, k_try) < k_new < max(k_cur, k_try) and abs(k_new - k_cur) > 1e-9 * max(abs(k_new), 1e-300)

"""Breakaway points of a root locus: double roots of ``1 + k L(s)``, located and crossed."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from linflex import LinearSystem

from ._locus_sums import _LoopSums
from ._zeros import _invariant_zeros


def _breakaways(L: LinearSystem, sign: float, sums: _LoopSums | None = None):
    """Double roots of 1 + k L(s): zeros of L'(s) = -c (sI - A)^-2 b with real gain -1/L(s).

    ``c (sI - A)^-2 b`` is the cascade of two copies of ``(A, b, c)``::

        [A 0] [b]
        [I A] [0]   [0 c]
    """
    A, b, c, d = L.A, L.B, L.C, L.D
    n = A.shape[0]
    A2 = np.block([[A, np.zeros((n, n))], [np.eye(n), A]])
    b2 = np.vstack([b, np.zeros((n, 1))])
    c2 = np.hstack([np.zeros((1, n)), c])
    cand = _invariant_zeros(A2, b2, c2, np.zeros((1, 1)))
    cand = cand[np.isfinite(cand)]
    if sums is not None:
        # the modal form: O(n) per candidate instead of a dense solve
        with np.errstate(all="ignore"):
            Ls = sums.values(cand)[0]
    else:
        Ls = np.full(len(cand), np.nan, dtype=complex)
        for i, s in enumerate(cand):
            try:
                Ls[i] = d[0, 0] + (c @ np.linalg.solve(s * np.eye(n) - A, b))[0, 0]
            except np.linalg.LinAlgError:
                continue
    pts, gains = [], []
    for s, Lval in zip(cand, Ls):
        if Lval == 0 or not np.isfinite(Lval):
            continue
        k = -1.0 / Lval
        if abs(k.imag) <= 1e-6 * abs(k) and sign * k.real > 0:
            pts.append(s)
            gains.append(k.real)
    order = np.argsort(np.abs(gains))
    return np.array(pts, dtype=complex)[order], np.array(gains, dtype=float)[order]


def _local_breakaway(sums: _LoopSums, prev: NDArray, new: NDArray, local: NDArray, k0: float, k1: float,
                     ahead: float = 1.0) -> tuple[float, complex] | None:
    """``(k_b, s_b)``: a double root of ``1 + k L`` with ``k_b`` strictly between ``k0`` and
    ``k0 + ahead (k1 - k0)``, next to the root that moved most from ``prev`` to ``new``, or
    ``None``.

    Newton on ``L'(s) = 0`` from the midpoint of that root and its nearest neighbour (two
    roots meet at a breakaway); ``k_b = -1/L(s_b)`` must be real."""
    if len(prev) < 2:
        return None
    j = int(np.argmax(np.abs(new - prev) / local))
    dist = np.abs(prev - prev[j])
    dist[j] = np.inf
    i = int(np.argmin(dist))
    mid = 0.5 * (prev[i] + prev[j])
    s = np.array([mid])
    if abs(s[0].imag) <= 1e-9 * max(1.0, abs(s[0])):
        s = s.real.astype(complex)
    with np.errstate(all="ignore"):
        for _ in range(30):
            d1, d2 = sums.derivatives(s)
            step = d1 / d2
            s = s - step
            # an iterate twice as far as a double root may lie is not converging to one here
            # (L' without a zero nearby, such as -n/s^(n+1) of 1/s^n: the iterates drift away)
            if not np.all(np.isfinite(s)) or abs(s[0] - mid) > 4 * dist[i]:
                return None
            if abs(step[0]) <= 1e-13 * max(1.0, abs(s[0])):
                break
        else:
            return None
        Ls = sums.values(s)[0][0]
    if abs(s[0] - mid) > 2 * dist[i] or Ls == 0 or not np.isfinite(Ls):
        return None
    k_b = -1.0 / Ls
    k2 = k0 + ahead * (k1 - k0)
    if abs(k_b.imag) > 1e-6 * abs(k_b) or not min(k0, k2) < k_b.real < max(k0, k2):
        return None
    return float(k_b.real), complex(s[0])


def _breakaway_near(bgains: NDArray, k0: float, k1: float, window: float = 3.0) -> int | None:
    """Index of the breakaway gain nearest to ``k0`` within ``window`` times the step from
    ``k0`` to ``k1`` on either side; ``None`` if there is none."""
    if bgains.size == 0:
        return None
    h = k1 - k0
    rel = (bgains - k0) / h if h != 0 else np.where(bgains == k0, 0.0, np.inf)
    near = np.flatnonzero((rel >= -window) & (rel <= window))
    if near.size == 0:
        return None
    return int(near[np.argmin(np.abs(bgains[near] - k0))])


def _any_between(bgains: NDArray, k0: float, k1: float) -> bool:
    """Whether a breakaway gain lies in the closed interval from ``k0`` to ``k1``."""
    return bool(np.any((bgains >= min(k0, k1)) & (bgains <= max(k0, k1))))


def _isolated_pair(r: NDArray, s_b: complex) -> NDArray | None:
    """Indices of the two roots nearest to ``s_b`` when every other root is at least twice as
    far from it as both of them, else ``None``."""
    if len(r) < 2:
        return None
    dist = np.abs(r - s_b)
    if len(r) == 2:
        return np.arange(2)
    idx = np.argpartition(dist, 2)[:3]
    idx = idx[np.argsort(dist[idx])]
    if 2.0 * dist[idx[1]] > dist[idx[2]]:
        return None
    return np.sort(idx[:2])


def _double_root_guess(sums: _LoopSums, r2: NDArray, k_cur: float, k_try: float, k_b: float,
                       s_b: complex) -> NDArray:
    """Guesses at ``k_try`` for the two roots ``r2`` (at ``k_cur``) meeting at the double root
    ``s_b`` (gain ``k_b``): the local expansion ``s_b +- w``, ``w^2 = 2 L^2 (k - k_b) / L''``
    (from ``1/L(s) + k = 0`` with ``L'(s_b) = 0``). Each takes the sign nearest to its own
    offset from ``s_b``, turned by 90 degrees when the step crosses ``k_b``."""
    with np.errstate(all="ignore"):
        Lb, _, d2 = sums.values(np.array([s_b], dtype=complex), second=True)
        w = np.sqrt(complex(2.0 * Lb[0] ** 2 * (k_try - k_b) / d2[0]))
    if not np.isfinite(w):
        return r2
    o = r2[0] - s_b
    if (k_try - k_b) * (k_cur - k_b) < 0:
        o = 1j * o
    sgn = 1.0 if (np.conj(w) * o).real >= 0 else -1.0
    return np.array([s_b + sgn * w, s_b - sgn * w])



"""Newton (Halley) continuation of the roots of ``1 + k L(s)`` for a SISO loop (root locus)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from linflex import LinearSystem

from ._locus_sums import _LoopSums


@dataclass(frozen=True)
class _Solved:
    """Roots at one gain, with what the solver learned there for the next step."""

    roots: NDArray[np.complex128]
    # [ds/dk, d2s/dk2] per root (shape (n, 2)), for the predictor; None if unknown
    dsdk: NDArray[np.complex128] | None
    # distance of each root to its nearest distinct other root, for the displacement test
    spacing: NDArray[np.float64] | None = None


class _NewtonTracker(_LoopSums):
    """Continuation of the roots of ``1 + k L(s)`` for a SISO loop, O(n^2) per gain step.

    ``L`` and its derivatives come from the modal sums of :class:`_LoopSums`. Each root is
    corrected by Newton's method on ``phi(s) = 1/L(s) + k`` (``s += L (1 + k L) / L'``, with
    Halley's correction), which is well scaled both near the poles (small gains) and near the
    zeros (large gains); a root leaves the iteration as soon as its own correction is at
    round-off. A step is rejected (and the caller falls back to a dense eigenvalue solve) unless
    every root converged, the roots are distinct, and their sum equals the trace of the
    closed-loop matrix.

    The loop is real, so its roots are real or come in conjugate pairs: when the previous roots
    hold verified pairs (``r[lo] == conj(r[up])``), only ``r[up]`` and the unpaired roots are
    iterated and ``conj(r[up])`` completes the set. The checks run on the completed set, so a
    pair that meets on the real axis (break-in) gives two coincident roots and is rejected, and
    roots that leave the real axis (breakaway) are unpaired and iterated individually.
    """

    def __init__(self, L: LinearSystem) -> None:
        super().__init__(L)
        self.traceA = float(np.trace(L.A))
        self.cb = float((L.C @ L.B)[0, 0])
        self.n = L.n_states
        # (roots, pairs) of the last two root sets, recognized by identity: the roots a step
        # returns are the ones the next step starts from
        self._pair_cache: list = []

    def leave_poles(self, poles: NDArray, k: float) -> NDArray | None:
        """Guesses for the roots at a small gain ``k`` in the order of the open-loop ``poles``:
        ``lambda - k r`` for a simple pole with residue ``r`` (first order in ``k``), and for a
        multiple pole ``mu`` (folded block, terms ``a_j / (s - mu)^(j+1)``) the roots of the
        local model ``x^p + k (a_0 x^(p-1) + a_1 x^(p-2) + ...) = 0``, ``x = s - mu``, of
        degree p = 2 or 3. ``None`` when the poles do not map onto the modal form."""
        if self.k_block:
            return None
        guess = np.asarray(poles, dtype=complex).copy()
        scale = max(1.0, float(np.max(np.abs(guess))))
        taken = np.zeros(len(guess), dtype=bool)
        for mu, coef, _ in self._multi:
            at = np.flatnonzero(np.abs(guess - mu) <= 1e-6 * scale)
            if len(at) != len(coef) + 1:
                return None
            hit = np.flatnonzero(np.abs(self.lam - mu) <= 1e-6 * scale)
            a0 = complex(self.r[hit[0]]) if hit.size else 0.0
            x = np.roots(np.r_[1.0, k * a0, k * np.asarray(coef)])
            if len(x) != len(at):
                return None
            guess[at] = mu + x
            taken[at] = True
        rest = np.flatnonzero(~taken)
        if not rest.size:
            return guess
        if not self.lam.size:
            return None
        near = np.argmin(np.abs(np.subtract.outer(guess[rest], self.lam)), axis=1)
        if np.any(np.abs(self.lam[near] - guess[rest]) > 1e-6 * scale):
            return None
        guess[rest] -= k * self.r[near]
        return guess

    def pairs(self, r: NDArray):
        """``(up, lo, single)`` indices with ``r[lo] == conj(r[up])`` to round-off, or ``None``."""
        for r_c, p_c in self._pair_cache:
            if r_c is r:
                return p_c
        self._remember_pairs(r, None)
        scale = max(1.0, float(np.max(np.abs(r))))
        tol = 1e-10 * scale
        up = np.flatnonzero(r.imag > tol)
        lo = np.flatnonzero(r.imag < -tol)
        if up.size == 0 or up.size != lo.size:
            return None
        # order both halves by |imag| then real part: partners take the same place
        up = up[np.lexsort((r[up].real, r[up].imag))]
        lo = lo[np.lexsort((r[lo].real, -r[lo].imag))]
        if np.max(np.abs(r[lo] - np.conj(r[up]))) > tol:
            return None
        single = np.setdiff1d(np.arange(len(r)), np.r_[up, lo], assume_unique=True)
        self._remember_pairs(r, (up, lo, single))
        return up, lo, single

    def _remember_pairs(self, r, pairs):
        self._pair_cache = [(r_c, p_c) for r_c, p_c in self._pair_cache if r_c is not r][-1:] + [(r, pairs)]

    def _newton(self, s: NDArray, k: NDArray):
        """Halley's iteration from ``s`` (modified in place) at the gains ``k`` (one per point):
        ``(s, last, converged)``; a point leaves the iteration as soon as its own error after
        the current update is at round-off. ``last`` holds, per point, ``L, L', L'', L'''``
        at its last evaluation and its last update, from which :func:`_branch_derivatives`
        gives ``ds/dk`` and ``d2s/dk2`` where they are needed (the predictor uses two rows).

        On ``phi(s) = 1/L(s) + k``: the Newton correction is ``delta = L (1 + k L) / L'``, and
        with ``e = L''/L'``, ``c = phi''/phi' = e - 2 L'/L``, ``t = c delta / 2``, Halley's
        update ``s += delta / (1 + t)`` converges cubically, leaving the error
        ``K delta^3``, ``K = C2^2 - C3 = e^2/4 - L^(3)/(6 L')`` (``Cj = phi^(j) / (j! phi')``).
        A point is converged when its relative residual ``|1 + k L|`` is at round-off, or when
        ``|t| <= 1e-3`` (inside the asymptotic region of the iteration) and
        ``|K| |delta|^3 <= 1e-14 max(1, |s|)``. Measured on the order-101 benchmark loop, the
        estimate is within a factor 2 of the true error (median ratio 1.0) where that error is
        above round-off; with the predictor most roots converge at their first evaluation,
        without a second one to confirm a negligible correction."""
        converged = np.zeros(len(s), dtype=bool)
        active = None
        sa, ka = s, k
        last = None
        # (called under step_many's np.errstate(all="ignore"): failed iterates may be inf/nan)
        for _ in range(12):
            Lr, dL, d2L, d3L = vals = self.values(sa, third=True)
            q = Lr / dL
            e = d2L / dL
            res = ka * Lr
            res += 1.0
            delta = q * res
            c = 2.0 / q
            np.subtract(e, c, out=c)
            t = c * delta
            t *= 0.5
            K = e * e
            K *= 0.25
            K -= d3L / (6.0 * dL)
            ad = np.abs(delta)
            err = np.abs(K)
            err *= ad
            err *= ad
            err *= ad
            # |k L| = 1 at a root, so |1 + k L| is a relative residual
            done = err <= 1e-14 * np.maximum(1.0, np.abs(sa))
            done &= np.abs(t) <= 1e-3
            done |= np.abs(res) <= 1e-13
            t += 1.0
            delta /= t
            if active is None:
                s += delta
                last = np.empty((5, len(s)), dtype=complex)
                last[:4] = vals
                last[4] = delta
                converged[:] = done
                active = np.flatnonzero(~done)
            else:
                s[active] = sa + delta
                last[:4, active] = vals
                last[4, active] = delta
                converged[active] = done
                active = active[~done]
            if active.size == 0:
                break
            sa, ka = s[active], k[active]
        return s, last, converged

    def step_many(self, R0: NDArray, ks: NDArray, prev: NDArray | None = None, loose: NDArray | None = None):
        """Roots at the gains ``ks`` from the guesses ``R0`` (one row per gain, in the order of
        the previous roots ``prev``, whose conjugate pairs are exploited), all in one
        vectorized Newton iteration.

        Returns ``(S, dS, spacing, coincident, ok)``: row ``i`` of ``S`` holds roots at
        ``ks[i]`` that passed every check when ``ok[i]``, and ``dS[i, :, 0]``, ``dS[i, :, 1]``
        the first and second derivatives of the roots with respect to ``k``."""
        # a failed iteration may hold inf/nan: the checks reject it, without warnings
        with np.errstate(all="ignore"):
            return self._step_many(R0, ks, prev, loose)

    def _step_many(self, R0: NDArray, ks: NDArray, prev: NDArray | None, loose: NDArray | None = None):
        G, n = R0.shape
        pr = self.pairs(prev) if prev is not None else None
        if pr is not None and loose is not None:
            up, lo, single = pr
            keep = ~(np.isin(up, loose) | np.isin(lo, loose))
            pr = (up[keep], lo[keep], np.sort(np.r_[single, up[~keep], lo[~keep]])) if keep.any() else None
        if pr is None:
            idx = np.arange(n)
            lo = idx[:0]
        else:
            up, lo, single = pr
            idx = np.concatenate([up, single])
        m, nu = len(idx), len(lo)
        ks = np.asarray(ks, dtype=float)
        st, last, conv = self._newton(np.array(R0[:, idx], dtype=complex).ravel(), np.repeat(ks, m))
        st = st.reshape(G, m)
        ok = conv.reshape(G, m).all(axis=1)
        S = np.empty((G, n), dtype=complex)
        S[:, idx] = st
        if nu:
            S[:, lo] = np.conj(st[:, :nu])
        dS = _BranchDerivatives(last.reshape(5, G, m), n, idx, lo)
        abs_st = np.abs(st)
        ok &= np.isfinite(abs_st).all(axis=1)
        spacing = np.full((G, n), np.inf)
        coincident = np.zeros(G, dtype=bool)
        if n > 1:
            # two iterates on one root: every root's nearest other root must be distinct from
            # it; the spacing beyond coincident roots is kept for the next displacement test
            smax = np.maximum(1.0, np.max(abs_st, axis=1))
            out = _nearest_conjugate(st, nu, 1e-6 * smax) if nu else None
            nearest, sp = out if out is not None else _nearest_many(S, 1e-6 * smax, idx)
            spacing[:, idx] = sp
            if nu:
                spacing[:, lo] = sp[:, :nu]
            near = np.min(nearest, axis=1)
            ok &= near > 1e-7 * smax
            coincident = near <= 1e-6 * smax
        # the sum of the roots is the trace of the closed-loop matrix A - k b c / (1 + k d)
        trace = self.traceA - ks * self.cb / (1.0 + ks * self.d.real)
        total = np.sum(S, axis=1)
        # sum of |roots|: the lower half plane mirrors the first nu iterated roots
        tol = 1e-8 * np.maximum(1.0, np.sum(abs_st, axis=1) + np.sum(abs_st[:, :nu], axis=1))
        ok &= (np.abs(total.real - trace) <= tol) & (np.abs(total.imag) <= tol)
        return S, dS, spacing, coincident, ok

    def step(self, r0: NDArray, k: float, prev: NDArray | None = None, loose: NDArray | None = None) -> _Solved | None:
        """Roots at gain ``k`` from the guesses ``r0``, or ``None`` when a check fails; see
        :meth:`step_many`. The roots ``loose`` (and their partners) are iterated on their own
        instead of as conjugate pairs: two roots crossing a double root on the real axis turn
        from a pair into two real roots or back."""
        S, dS, spacing, _, ok = self.step_many(r0[None, :], np.array([k]), prev, loose)
        if not ok[0]:
            return None
        s = S[0]
        if loose is None:
            self.remember(prev, s)
        return _Solved(s, dS[0], spacing[0])

    def remember(self, prev: NDArray | None, s: NDArray) -> None:
        """The pairs of ``prev`` carry over to ``s`` (exactly conjugate by construction)."""
        pr = self.pairs(prev) if prev is not None else None
        if pr is not None:
            self._remember_pairs(s, pr)



def _branch_derivatives(Lr: NDArray, dL: NDArray, d2L: NDArray, d3L: NDArray, delta: NDArray) -> NDArray:
    """``[ds/dk, d2s/dk2]`` per root at the updated points ``s + delta`` from ``L`` and its
    first three derivatives at the evaluated points ``s``.

    ``ds/dk = T = L^2 / L'`` and ``d2s/dk2 = a = -c T^2`` (:func:`_tangents`), carried to the
    updated point to first order in ``delta`` (a root accepted after one Halley update can be
    ``delta ~ 1e-6`` away, too far for the predictor): with ``e = L''/L'``, ``p = L'/L``,
    ``c = e - 2 p``: ``dT/ds = 2 L - e T``, ``dc/ds = L^(3)/L' - e^2 - 2 e p + 2 p^2`` and
    ``da/ds = -(dc T^2 + 2 c T dT)``."""
    q = Lr / dL
    e = d2L / dL
    p = 1.0 / q
    c = e - 2.0 * p
    T = q * Lr
    dT = 2.0 * Lr - e * T
    dc = d3L / dL - e * e - 2.0 * e * p + 2.0 * p * p
    out = np.empty((len(Lr), 2), dtype=complex)
    out[:, 0] = T + dT * delta
    out[:, 1] = -(c * T * T + (dc * T + 2.0 * c * dT) * T * delta)
    return out


class _BranchDerivatives:
    """Rows of ``[ds/dk, d2s/dk2]`` (shape (n, 2)) of a batch of root sets, computed for the
    whole batch at once when a row is first asked for (not at every Halley iteration)."""

    def __init__(self, last: NDArray, n: int, idx: NDArray, lo: NDArray) -> None:
        self._last, self._n, self._idx, self._lo = last, n, idx, lo
        self._rows = None

    def __len__(self) -> int:
        return self._last.shape[1]

    def __getitem__(self, j: int) -> NDArray:
        if self._rows is None:
            _, G, m = self._last.shape
            self._rows = _branch_derivatives(*self._last.reshape(5, G * m)).reshape(G, m, 2)
        d = self._rows[j]
        out = np.empty((self._n, 2), dtype=complex)
        out[self._idx] = d
        if len(self._lo):
            out[self._lo] = np.conj(d[:len(self._lo)])
        return out


def _tangents(Lr: NDArray, dL: NDArray, d2L: NDArray, out: NDArray | None = None) -> NDArray:
    """``[ds/dk, d2s/dk2]`` of the roots of ``1/L(s) + k = 0`` from ``L, L', L''`` there.

    With ``phi = 1/L``: ``phi' s' = -1`` gives ``s' = L^2 / L'``, and ``phi'' s'^2 + phi' s'' = 0``
    gives ``s'' = -(L''/L' - 2 L'/L) s'^2``."""
    if out is None:
        out = np.empty((len(Lr), 2), dtype=complex)
    d1 = Lr * Lr / dL
    out[:, 0] = d1
    out[:, 1] = (2.0 * dL / Lr - d2L / dL) * (d1 * d1)
    return out


def _nearest_conjugate(Su: NDArray, nu: int, same: NDArray):
    """:func:`_nearest_many` for root sets closed under conjugation, from the iterated roots
    ``Su`` alone (per row: ``nu`` roots of the upper half plane, then the real ones), or
    ``None`` when two roots coincide (the caller then takes all roots).

    For ``u, v`` in the upper half plane ``|u - conj(v)| >= |u - v|``, and a real ``x`` is as
    far from ``conj(v)`` as from ``v``: the lower half plane holds no nearer root than the
    upper one except each root's own conjugate, at ``2 Im(u)``. Half the distances."""
    m = Su.shape[1]
    re = np.ascontiguousarray(Su.real)
    im = np.ascontiguousarray(Su.imag)
    dx = re[:, :, None] - re[:, None, :]
    dy = im[:, :, None] - im[:, None, :]
    dx *= dx
    dy *= dy
    dx += dy
    ar = np.arange(m)
    dx[:, ar, ar] = np.inf
    nearest2 = np.min(dx, axis=2)
    own = 2.0 * im[:, :nu]
    np.minimum(nearest2[:, :nu], own * own, out=nearest2[:, :nu])
    if np.any(nearest2 <= (same * same)[:, None]):
        return None
    nearest = np.sqrt(nearest2)
    return nearest, nearest


def _nearest_many(S: NDArray, same: NDArray, rows: NDArray):
    """:func:`_nearest` for each row of ``S`` (one root set per gain), from the roots
    ``S[:, rows]``; in chunks of gains whose distance arrays stay in cache."""
    G, n = S.shape
    c = max(1, (1 << 15) // max(1, len(rows) * n))
    if G > c:
        parts = [_nearest_many(S[i:i + c], same[i:i + c], rows) for i in range(0, G, c)]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    Sr = S[:, rows]
    dx = Sr.real[:, :, None] - S.real[:, None, :]
    dy = Sr.imag[:, :, None] - S.imag[:, None, :]
    dx *= dx
    dy *= dy
    dx += dy
    dx[:, np.arange(len(rows)), rows] = np.inf
    nearest2 = np.min(dx, axis=2)
    same2 = (same * same)[:, None]
    if not np.any(nearest2 <= same2):
        # no coincident roots (the common case): the nearest root is the spacing
        nearest = np.sqrt(nearest2)
        return nearest, nearest
    dx[dx <= same2[:, :, None]] = np.inf
    return np.sqrt(nearest2), np.sqrt(np.min(dx, axis=2))



"""Root locus: closed-loop eigenvalues over a scalar loop gain, tracked branch by branch."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from linflex import LinearSystem, ModelError, ShapeError, as_linear_system

from ._loop import Loop
from ._zeros import _invariant_zeros

_EPS = np.finfo(float).eps

__all__ = ["RootLocus", "root_locus"]


@dataclass(frozen=True)
class RootLocus:
    """Closed-loop eigenvalues of ``x' = (A - k B (I + k D)^-1 C) x`` over the gain ``k``.

    Attributes
    ----------
    gains : numpy.ndarray, shape (n_gains,)
        Loop gains [-] (dimensionless when the loop transfer function is; in general the
        inverse of its units), monotone (increasing for ``k >= 0``, decreasing for the
        complementary locus); the first is 0 for an automatic sequence.
    roots : numpy.ndarray of complex, shape (n_gains, n_states)
        ``roots[:, j]`` is branch ``j``: consecutive rows are matched by minimum total
        displacement (linear assignment) or carried by the continuation, so a branch is a
        continuous curve [1/s].
    open_loop_poles, open_loop_zeros : numpy.ndarray of complex
        Start and (finite) end points of the branches [1/s].
    breakaway_points : numpy.ndarray of complex
        Points [1/s] where two branches meet and leave (SISO loops; empty otherwise): double roots
        of ``1 + k L(s)``; all of them with the pencil (``breakaway=True``, the default for an
        automatic sequence up to 200 states), else those the continuation located between the
        gains it crossed.
    breakaway_gains : numpy.ndarray
        The gains at those points [-] (real, of the sign of the locus).
    max_step_displacement : float
        Largest accepted root displacement between consecutive gains, relative to the local
        root spacing [-]; the matching is reliable when this is well below 0.5.
    n_eigenvalue_solves : int
        Dense eigenvalue solves.
    n_continuation_steps : int
        Gain steps taken by Newton continuation instead.
    n_rejected_continuation_steps : int
        Continuation steps that failed their checks and were replaced by a smaller step or a
        dense solve (after three in a row, dense solves take over for a while).
    seconds : float
        Wall time of :func:`root_locus` [s].
    """

    gains: NDArray[np.float64]
    roots: NDArray[np.complex128]
    open_loop_poles: NDArray[np.complex128]
    open_loop_zeros: NDArray[np.complex128]
    breakaway_points: NDArray[np.complex128]
    breakaway_gains: NDArray[np.float64]
    max_step_displacement: float
    n_eigenvalue_solves: int
    n_continuation_steps: int
    n_rejected_continuation_steps: int
    seconds: float

    @property
    def branches(self) -> list[NDArray[np.complex128]]:
        """The branches as a list of arrays of shape (n_gains,)."""
        return [self.roots[:, j] for j in range(self.roots.shape[1])]

    def plot(self, **kwargs):
        """Root-locus plot: see :func:`linflex.frequency.root_locus_plot`.

        Parameters
        ----------
        **kwargs
            ``ax=`` and line options, passed to :func:`root_locus_plot`.

        Returns
        -------
        PlotHandle
            The figure, the axes and the lines (branches, then the pole and zero markers).
        """
        from ._plot import root_locus_plot

        return root_locus_plot(self, **kwargs)


class _ClosedLoop:
    """Eigenvalues of the closed loop at gain ``k``, on the Hessenberg form of ``A``."""

    def __init__(self, L: LinearSystem) -> None:
        self.L = L
        # One similarity to Hessenberg form: eigenvalues are unchanged and LAPACK's reduction
        # works on a matrix that is already nearly reduced when B C is low rank.
        self.A = L.A
        self.B, self.C, self.D = L.B, L.C, L.D
        self.count = 0
        self.I = np.eye(L.n_inputs)

    def matrix(self, k: float) -> NDArray[np.float64]:
        if k == 0:
            return self.A
        F = self.I + k * self.D
        try:
            KC = np.linalg.solve(F, self.C) * k
        except np.linalg.LinAlgError:
            raise ModelError(f"the loop is ill-posed at gain {k}: I + k D is singular") from None
        return self.A - self.B @ KC

    def eig(self, k: float) -> NDArray[np.complex128]:
        self.count += 1
        return scipy.linalg.eigvals(self.matrix(k), overwrite_a=bool(k != 0), check_finite=False)


class _NewtonTracker:
    """Continuation of the roots of ``1 + k L(s)`` for a SISO loop, O(n^2) per gain step.

    ``L(s) = d + sum_i r_i / (s - lambda_i) + C1 (sI - T11)^-1 B1`` from the block-diagonal
    modal form (the small block holds defective rigid-body eigenvalues). Each root is corrected
    by Newton's method on ``phi(s) = 1/L(s) + k`` (``s += L (1 + k L) / L'``), which is well
    scaled both near the poles (small gains) and near the zeros (large gains); a root leaves the
    iteration as soon as its own correction is at round-off. A step is rejected (and the caller
    falls back to a dense eigenvalue solve) unless every root converged, the roots are distinct,
    and their sum equals the trace of the closed-loop matrix.

    The loop is real, so its roots are real or come in conjugate pairs: when the previous roots
    hold verified pairs (``r[lo] == conj(r[up])``), only ``r[up]`` and the unpaired roots are
    iterated and ``conj(r[up])`` completes the set. The checks run on the completed set, so a
    pair that meets on the real axis (break-in) gives two coincident roots and is rejected, and
    roots that leave the real axis (breakaway) are unpaired and iterated individually.
    """

    def __init__(self, L: LinearSystem) -> None:
        from ._response import _Modal

        m = _Modal(L)
        self.lam = np.ascontiguousarray(m.lam)
        self.r = np.ascontiguousarray(m.K[:, 0])
        self.d = complex(L.D[0, 0])
        self.k_block = m.k
        if m.k:
            self.T11, self.B1, self.C1 = m.T11, m.B1[:, 0], m.C1[0]
            self._tdiag = np.diag(m.T11).copy()
            self._NT = np.triu(m.T11, 1).T.copy()
        self.cond = m.cond
        self.poles = np.asarray(m.poles, dtype=complex)
        self.traceA = float(np.trace(L.A))
        self.cb = float((L.C @ L.B)[0, 0])
        self.n = L.n_states
        scale_r = np.abs(self.r)
        if scale_r.size and np.min(scale_r) <= 1e-13 * np.max(scale_r):
            # a mode the loop cannot move (uncontrollable or unobservable): not a root of 1 + kL
            raise ValueError("a mode with zero residue")
        if self.cond > 1e8:
            raise ValueError("modal form too ill-conditioned for continuation")
        self._multi: list = []
        if self.k_block:
            self._fold_block()
        self._fold_pairs()
        self._pair_cache: list = []   # (roots, pairs) of the last two root sets
        self.dsdk = None
        self.spacing = None
        self.coincident = False

    def _fold_block(self) -> None:
        """Partial fractions of the small block ``C1 (sI - T11)^-1 B1`` when they are exact and
        well conditioned: its diagonal in groups of exactly equal entries (a Jordan-like block
        such as the rigid body's double pole keeps exactly repeated values), contiguous, and
        decoupled by Sylvester solves ``X`` with ``||X|| <= 1e3``. Then each group is
        ``mu I + N`` with ``N`` strictly upper (nilpotent), and

            C (sI - mu I - N)^-1 B = sum_j  C N^j B / (s - mu)^(j+1),   j < size of the group,

        a finite sum: the simple-pole terms join the Cauchy sums, the higher powers are a few
        extra terms. The general block evaluation (a triangular solve per point) stays
        otherwise."""
        T, B, C = self.T11, self.B1.astype(complex), self.C1.astype(complex)
        t = np.diag(T)
        k = len(t)
        starts = [0] + [i for i in range(1, k) if t[i] != t[i - 1]]
        if len({complex(t[i]) for i in starts}) != len(starts):
            return   # a value repeated in two places: the groups are not contiguous
        bounds = starts + [k]
        simple, multi = [], []
        T = T.copy()
        for g in range(len(starts)):
            i0, i1 = bounds[g], bounds[g + 1]
            if i1 < k:
                # decouple this group from the rest: T_gg X - X T_rr = -T_gr
                X = scipy.linalg.solve_sylvester(T[i0:i1, i0:i1], -T[i1:, i1:], -T[i0:i1, i1:])
                if not np.all(np.isfinite(X)) or np.linalg.norm(X, 1) > 1e3:
                    return
                B[i0:i1] = B[i0:i1] - X @ B[i1:]
                C[i1:] = C[i1:] + C[i0:i1] @ X
            mu = complex(t[i0])
            N = T[i0:i1, i0:i1] - mu * np.eye(i1 - i0)
            coef, v = [], B[i0:i1]
            for _ in range(i1 - i0):
                coef.append(complex(C[i0:i1] @ v))
                v = N @ v
            if coef[0] != 0:
                simple.append((mu, coef[0]))
            if any(c != 0 for c in coef[1:]):
                multi.append((mu, np.array(coef[1:])))
        if simple:
            self.lam = np.ascontiguousarray(np.r_[self.lam, [mu for mu, _ in simple]])
            self.r = np.ascontiguousarray(np.r_[self.r, [c for _, c in simple]])
        self._multi = [(mu, coef, _power_terms(coef)) for mu, coef in multi]
        self.k_block = 0

    def leave_poles(self, poles: NDArray, k: float) -> NDArray | None:
        """Guesses for the roots at a small gain ``k`` in the order of the open-loop ``poles``:
        ``lambda - k r`` for a simple pole with residue ``r`` (first order in ``k``), and for a
        multiple pole ``mu`` (folded block, terms ``a_j / (s - mu)^(j+1)``) the roots of the
        local model ``x^p + k (a_0 x^(p-1) + a_1 x^(p-2) + ...) = 0``, ``x = s - mu``, of
        degree p = 2 or 3. ``None`` when the poles do not map onto the modal form."""
        if self.k_block:
            return None
        guess = np.asarray(poles, dtype=complex).copy()
        near = np.argmin(np.abs(np.subtract.outer(guess, self.lam)), axis=1)
        scale = max(1.0, float(np.max(np.abs(self.lam))))
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
        rest = ~taken
        if np.any(np.abs(self.lam[near[rest]] - guess[rest]) > 1e-6 * scale):
            return None
        guess[rest] -= k * self.r[near[rest]]
        return guess

    def _fold_pairs(self) -> None:
        """Real-coefficient form of the pole sums, evaluated by :meth:`_folded_sums`.

        A conjugate pair ``r/(s - lambda) + conj(r)/(s - conj(lambda))`` is one term over
        ``q = (s - lambda)(s - conj lambda) = s^2 + a1 s + a0`` (``a1 = -2 Re lambda``,
        ``a0 = |lambda|^2``, both real). With ``v = s - conj(lambda)``, ``1/(s - lambda) = v w``
        (``w = 1/q``) and ``v^2 = q + (lambda - conj lambda) v``, so ``v^n = A_n(q) v + B_n(q)``
        (``A_1 = 1, B_1 = 0``, ``A_(n+1) = (lambda - conj lambda) A_n + B_n``, ``B_(n+1) = q
        A_n``), and the j-th derivative of the pair is, n = j + 1::

            (-1)^j j! [r v^n + conj(r v^n)] w^n = (-1)^j j! sum_i (beta_i s + gamma_i) w^(n-i)

            beta_i = 2 Re(r A_n,i),  gamma_i = 2 Re(r B_n,i) - 2 Re(r A_n,i conj lambda)

        (``A_n,i`` the coefficient of ``q^i``): real coefficients times powers of ``w``, and a
        factor ``s`` applied once per point after the sums over the terms. A real pole ``p``
        (residue ``rho``) is the term ``q = s - p`` with ``(-1)^j j! rho w^n``; a real
        multiple pole of the folded block (``a_c / (s - mu)^(c+2)``) adds to the column of
        ``q = s - mu``. Per point and term: one complex reciprocal per pair instead of two,
        and the sums are real matrices times the interleaved complex ones (real GEMMs).

        Error: ``q`` carries ``eps (|s|^2 + |lambda|^2)`` absolutely, as if the pole moved by
        that over ``|s - conj lambda|``: at most ``sqrt 2 eps |lambda|`` next to the pole when
        ``Im lambda >= |Re lambda|`` (damping ``zeta <= 1/sqrt 2``), the size of rounding the
        pole itself (relative to the partial fractions, the value there is off by about ``eps
        |lambda| / |s - lambda|``). Better damped pairs (``|lambda| / (2 Im lambda)`` times
        more), poles without a conjugate partner to round-off and complex residues of real
        poles keep the complex Cauchy sums. The sums in powers of ``w`` were measured within
        8 eps of the partial fractions' own round-off scale (single pairs of every damping and
        residue phase; tests/frequency/test_locus.py). The modal residues of a real loop are
        conjugate only to round-off: a folded pair takes their mean (the exactly
        conjugate-symmetric loop)."""
        lam, r = self.lam, self.r
        used = np.zeros(len(lam), dtype=bool)
        up, lower = np.flatnonzero(lam.imag > 0), np.flatnonzero(lam.imag < 0)
        lo = up[:0]
        if up.size and lower.size:
            lo = lower[np.argmin(np.abs(lam[lower][None, :] - np.conj(lam[up])[:, None]), axis=1)]
            ok = np.abs(lam[lo] - np.conj(lam[up])) <= 1e-10 * np.abs(lam[up])
            ok &= np.abs(r[lo] - np.conj(r[up])) <= 1e-10 * np.abs(r[up])
            ok &= lam[up].imag >= np.abs(lam[up].real)
            # a partner claimed twice (repeated poles): neither pair is folded
            vals, counts = np.unique(lo[ok], return_counts=True)
            ok &= ~np.isin(lo, vals[counts > 1])
            up, lo = up[ok], lo[ok]
        used[up] = used[lo] = True
        mu = 0.5 * (lam[up] + np.conj(lam[lo]))
        rho = 0.5 * (r[up] + np.conj(r[lo]))
        real = ~used & (np.abs(lam.imag) <= 1e-12 * np.abs(lam)) & (np.abs(r.imag) <= 1e-10 * np.abs(r))
        used |= real
        p_real, rho_real = list(lam[real].real), list(r[real].real)
        self._lam_rest = np.ascontiguousarray(lam[~used])
        self._r_rest = np.ascontiguousarray(r[~used])
        # real multiple poles of the folded block: in the column of an equal real pole, or
        # their own (with no simple term)
        npair = len(mu)
        multi, self._multi_rest = [], []
        for mu_m, a, mats in self._multi:
            if abs(mu_m.imag) <= 1e-12 * abs(mu_m) and np.all(np.abs(a.imag) <= 1e-10 * np.abs(a)):
                if mu_m.real not in p_real:
                    p_real.append(mu_m.real)
                    rho_real.append(0.0)
                multi.append((npair + p_real.index(mu_m.real), a.real))
            else:
                self._multi_rest.append((mu_m, a, mats))
        nf = npair + len(p_real)
        self._nf = nf
        # q = A[:, 0] + A[:, 1] s + A[:, 2] s^2 per term
        A = np.zeros((nf, 3))
        A[:npair] = np.c_[np.abs(mu) ** 2, -2.0 * mu.real, np.ones(npair)]
        A[npair:, 0] = -np.array(p_real)
        A[npair:, 1] = 1.0
        # coefficient vectors over the terms, keyed (derivative j, power of w, 1 for beta
        # (times s) or 0 for gamma)
        coef: dict = {}

        def add(coef, j, pw, kind, cols, x):
            coef.setdefault((j, pw, kind), np.zeros(nf))[cols] += x

        # v^n = sum_i An[i] q^i v + Bn[i] q^i, from n = 1
        d = mu - np.conj(mu)
        An, Bn = [np.ones(npair, dtype=complex)], [np.zeros(npair, dtype=complex)]
        fact = 1.0
        pairs = slice(0, npair)
        for j in range(4):
            for i in range(len(Bn)):
                ra = rho * An[i] if i < len(An) else 0.0 * rho
                add(coef, j, j + 1 - i, 1, pairs, fact * 2.0 * ra.real)
                add(coef, j, j + 1 - i, 0, pairs, fact * 2.0 * ((rho * Bn[i]).real - (ra * np.conj(mu)).real))
            add(coef, j, j + 1, 0, slice(npair, nf), fact * np.array(rho_real))
            An, Bn = ([d * An[i] + Bn[i] if i < len(An) else Bn[i] for i in range(len(Bn))], [0.0 * d] + An)
            fact *= -(j + 1)
        # a_c w^b, b = c + 2: the j-th derivative is a_c (-1)^j b (b+1) ... (b+j-1) w^(b+j)
        powers = []
        for col, a in multi:
            for c, ac in enumerate(a):
                f = float(ac)
                for j in range(4):
                    b = c + 2 + j
                    powers.append((j, b, col, f))
                    f *= -b
        self._fA = A
        # per highest order o: per power p of w, the coefficient rows (a real matrix); the rows
        # of all powers, stacked, map to X_j (times s) and Y_j by a 0/1 matrix: L^(j) = s X_j + Y_j
        self._fplan = {}
        for o in (1, 2, 3):
            co = {k: v.copy() for k, v in coef.items()}
            extras = []
            for j, b, col, f in powers:
                if j > o:
                    continue
                if b <= o + 1:
                    add(co, j, b, 0, col, f)
                else:
                    extras.append((j, b - (o + 1), col, f))
            mats, mix_rows = [], []
            for pw in range(1, o + 2):
                keys = [k for k in sorted(co) if k[1] == pw and k[0] <= o and np.any(co[k])]
                mats.append(np.array([co[k] for k in keys]).reshape(len(keys), nf))
                mix_rows += [k[0] + (o + 1) * (1 - k[2]) for k in keys]
            mix = np.zeros((2 * (o + 1), len(mix_rows)))
            mix[mix_rows, np.arange(len(mix_rows))] = 1.0
            off = np.cumsum([0] + [len(M) for M in mats])
            # for a few points (numpy's per-call cost dominates), the powers stacked and one
            # product: mix @ blockdiag(mats) on [w; w^2; ...]
            blocks = np.zeros((int(off[-1]), (o + 1) * nf))
            for p, M in enumerate(mats):
                blocks[off[p]:off[p + 1], p * nf:(p + 1) * nf] = M
            self._fplan[o] = (mats, off, mix, extras, mix @ blocks)
        # work arrays reused by every evaluation (a fresh array per call costs more in page
        # faults than the arithmetic), sized to stay in cache: many points go in chunks
        self._fchunk = max(8, (1 << 15) // max(1, nf))
        self._fW = np.empty(self._fchunk * nf, dtype=complex)
        self._fW2 = np.empty_like(self._fW)
        self._fP = np.empty(3 * self._fchunk, dtype=complex)
        self._fR = np.empty(max(1, int(self._fplan[3][1][-1])) * self._fchunk, dtype=complex)
        self._fXY = np.empty(8 * self._fchunk, dtype=complex)
        self._fsmall = max(4, (1 << 12) // max(1, nf))
        self._fS = np.empty(4 * nf * self._fsmall, dtype=complex)

    def _folded_sums(self, s, order: int, out) -> None:
        """The folded terms of :meth:`_fold_pairs` and their derivatives up to ``order``
        at the points ``s``, into ``out`` (shape (order + 1, len(s)))."""
        nf, c, A = self._nf, self._fchunk, self._fA
        mats, off, mix, extras, full = self._fplan[order]
        m = len(s)
        if m <= self._fsmall:
            P = self._fP[:3 * m].reshape(3, m)
            P[0] = 1.0
            P[1] = s
            np.multiply(s, s, out=P[2])
            S = self._fS[:(order + 1) * nf * m].reshape(-1, m)
            W = S[:nf]
            np.matmul(A, P.view(float), out=W.view(float))
            np.reciprocal(W, out=W)
            for p in range(1, order + 1):
                np.multiply(S[(p - 1) * nf:p * nf], W, out=S[p * nf:(p + 1) * nf])
            XY = self._fXY[:2 * (order + 1) * m].reshape(-1, m)
            np.matmul(full, S.view(float), out=XY.view(float))
            np.multiply(XY[:order + 1], s, out=out)
            out += XY[order + 1:]
            for j, e, t, f in extras:
                x = S[order * nf + t] * f
                for _ in range(e):
                    x *= W[t]
                out[j] += x
            return
        for i0 in range(0, m, c):
            i1 = min(m, i0 + c)
            mc = i1 - i0
            sc = s[i0:i1]
            # q of every term at every point: a real (nf x 3) times (3 x 2 mc) product on the
            # interleaved real and imaginary parts of the rows 1, s, s^2
            P = self._fP[:3 * mc].reshape(3, mc)
            P[0] = 1.0
            P[1] = sc
            np.multiply(sc, sc, out=P[2])
            W = self._fW[:nf * mc].reshape(nf, mc)
            np.matmul(A, P.view(float), out=W.view(float))
            np.reciprocal(W, out=W)
            R = self._fR[:off[-1] * mc].reshape(-1, mc)
            np.matmul(mats[0], W.view(float), out=R[:off[1]].view(float))
            Wp = self._fW2[:nf * mc].reshape(nf, mc)
            np.multiply(W, W, out=Wp)
            np.matmul(mats[1], Wp.view(float), out=R[off[1]:off[2]].view(float))
            for p in range(2, order + 1):
                np.multiply(Wp, W, out=Wp)
                np.matmul(mats[p], Wp.view(float), out=R[off[p]:off[p + 1]].view(float))
            XY = self._fXY[:2 * (order + 1) * mc].reshape(-1, mc)
            np.matmul(mix, R.view(float), out=XY.view(float))
            np.multiply(XY[:order + 1], sc, out=out[:, i0:i1])
            out[:, i0:i1] += XY[order + 1:]
            for j, e, t, f in extras:
                # powers of w beyond order + 1 (multiple poles): from the last power's row
                x = Wp[t] * f
                for _ in range(e):
                    x *= W[t]
                out[j, i0:i1] += x

    def values(self, s, second: bool = False, third: bool = False):
        """``L(s)`` and ``L'(s)`` at the points ``s``, then ``L''(s)`` with ``second=True`` and
        also the third derivative with ``third=True``: an array of shape (order + 1, len(s))."""
        order = 3 if third else (2 if second else 1)
        out = np.empty((order + 1, len(s)), dtype=complex)
        if self._nf:
            self._folded_sums(s, order, out)
        else:
            out[:] = 0.0
        if len(self._lam_rest):
            out += _cauchy_sums(s, self._lam_rest, self._r_rest, order)
        if self.d != 0:
            out[0] += self.d
        for mu, _, mats in self._multi_rest:
            # sum_j a_j w^(j+1), j >= 1, w = 1/(s - mu), and its derivatives: the powers
            # w^2, w^3, ... once, each term f w^p added to its derivative's row (a few
            # operations on vectors: a matrix product of this shape costs 10x more)
            w = 1.0 / (s - mu)
            M = mats[order]
            wp = w * w
            for row in M:
                for i in np.flatnonzero(row):
                    out[i] += row[i] * wp
                wp = wp * w
        if self.k_block:
            # T11 = Dg + N (complex Schur form: diagonal plus strictly upper, nilpotent), so
            # (sI - T11)^-1 = (I - Q N)^-1 Q with Q = (sI - Dg)^-1, a Neumann series of k_block
            # terms: x = (sI - T11)^-1 B1, x2 = (sI - T11)^-1 x, ..., for all s at once; the
            # i-th derivative of C1 (sI - T11)^-1 B1 is (-1)^i i! C1 (sI - T11)^-(i+1) B1
            Q = 1.0 / np.subtract.outer(s, self._tdiag)
            X = self.B1
            f = 1.0
            for i in range(order + 1):
                X = self._block_solve(Q, X)
                out[i] += f * (X @ self.C1)
                f *= -(i + 1)
        return out

    def _block_solve(self, Q, rhs):
        """``(sI - T11)^-1 rhs`` for each point s (row of ``Q = 1/(s - diag T11)``)."""
        X = Q * rhs
        for _ in range(self.k_block - 1):
            X = Q * (rhs + X @ self._NT)
        return X

    def derivatives(self, s: NDArray):
        """``L'(s)`` and ``L''(s)`` at the points ``s``."""
        return self.values(np.asarray(s, dtype=complex), second=True)[1:]

    def local_breakaway(self, prev: NDArray, new: NDArray, local: NDArray, k0: float, k1: float,
                        ahead: float = 1.0):
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
        s = np.array([0.5 * (prev[i] + prev[j])])
        if abs(s[0].imag) <= 1e-9 * max(1.0, abs(s[0])):
            s = s.real.astype(complex)
        with np.errstate(all="ignore"):
            for _ in range(30):
                d1, d2 = self.derivatives(s)
                step = d1 / d2
                s = s - step
                if not np.all(np.isfinite(s)):
                    return None
                if abs(step[0]) <= 1e-13 * max(1.0, abs(s[0])):
                    break
            else:
                return None
            Ls = self.values(s)[0][0]
        if abs(s[0] - 0.5 * (prev[i] + prev[j])) > 2 * dist[i] or Ls == 0 or not np.isfinite(Ls):
            return None
        k_b = -1.0 / Ls
        k2 = k0 + ahead * (k1 - k0)
        if abs(k_b.imag) > 1e-6 * abs(k_b) or not min(k0, k2) < k_b.real < max(k0, k2):
            return None
        return float(k_b.real), complex(s[0])

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

    def step(self, r0: NDArray, k: float, prev: NDArray | None = None, loose: NDArray | None = None) -> NDArray | None:
        """Roots at gain ``k`` from the guesses ``r0``, or ``None`` when a check fails; see
        :meth:`step_many`. The roots ``loose`` (and their partners) are iterated on their own
        instead of as conjugate pairs: two roots crossing a double root on the real axis turn
        from a pair into two real roots or back."""
        S, dS, spacing, coincident, ok = self.step_many(r0[None, :], np.array([k]), prev, loose)
        if not ok[0]:
            return None
        s = S[0]
        if loose is None:
            self.remember(prev, s)
        self.dsdk, self.spacing, self.coincident = dS[0], spacing[0], bool(coincident[0])
        return s

    def remember(self, prev: NDArray | None, s: NDArray) -> None:
        """The pairs of ``prev`` carry over to ``s`` (exactly conjugate by construction)."""
        pr = self.pairs(prev) if prev is not None else None
        if pr is not None:
            self._remember_pairs(s, pr)


def _cauchy_sums(s: NDArray, lam: NDArray, r: NDArray, order: int) -> NDArray:
    """``sum_i r_i / (s - lambda_i)`` and its derivatives up to ``order`` at the points ``s``:
    shape (order + 1, len(s)). The j-th derivative of ``r/(s - lambda)`` is
    ``(-1)^j j! r/(s - lambda)^(j+1)``; rows of the Cauchy matrix ``1/(s_i - lambda_j)`` in
    chunks of 256 KiB (in cache)."""
    m, n = len(s), len(lam)
    c = max(8, (1 << 14) // max(1, n))
    out = np.empty((order + 1, m), dtype=complex)
    W = np.empty((min(c, m), n), dtype=complex)
    Wp = np.empty_like(W)
    for i0 in range(0, m, c):
        i1 = min(m, i0 + c)
        Wc, Wpc = W[:i1 - i0], Wp[:i1 - i0]
        np.subtract.outer(s[i0:i1], lam, out=Wc)
        np.reciprocal(Wc, out=Wc)
        np.matmul(Wc, r, out=out[0, i0:i1])
        np.multiply(Wc, Wc, out=Wpc)
        np.matmul(Wpc, r, out=out[1, i0:i1])
        for j in range(2, order + 1):
            np.multiply(Wpc, Wc, out=Wpc)
            np.matmul(Wpc, r, out=out[j, i0:i1])
    f = 1.0
    for j in range(1, order + 1):
        f *= -j
        out[j] *= f
    return out


def _power_terms(coef: NDArray) -> dict:
    """Per highest derivative order ``o``: the matrix ``M`` with ``[w^2, w^3, ...] @ M`` the
    values and derivatives (columns 0..o) of ``sum_j coef[j-1] w^(j+1)``, ``w = 1/(s - mu)``.

    The i-th derivative of ``a w^p`` is ``a (-1)^i p (p+1) ... (p+i-1) w^(p+i)``."""
    mats = {}
    for o in (1, 2, 3):
        M = np.zeros((len(coef) + o, o + 1), dtype=complex)
        for j, a in enumerate(coef, start=1):
            p, f = j + 1, complex(a)
            for i in range(o + 1):
                M[j - 1 + i, i] = f
                f = -f * (p + i)
        mats[o] = M
    return mats


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


def _match(prev: NDArray, new: NDArray) -> NDArray:
    cost = np.abs(prev[:, None] - new[None, :])
    r, c = linear_sum_assignment(cost)
    out = np.empty_like(new)
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
        self._coincident = False

    def local(self, prev: NDArray, spacing: NDArray | None = None, coincident: bool = False) -> NDArray:
        if self._of is prev:
            return self._local
        n = len(prev)
        if spacing is None:
            if n > 1:
                same = 1e-6 * max(1.0, float(np.max(np.abs(prev))))
                nearest, spacing = _nearest(prev, same)
                coincident = bool(np.min(nearest) <= same)
            else:
                spacing = np.full(n, np.inf)
        self._of = prev
        self._coincident = coincident
        self._local = np.minimum(spacing, np.abs(prev) + self.s_ref) + self.s_ref
        return self._local

    def coincident(self, prev: NDArray) -> bool:
        """Whether two of the roots ``prev`` coincide to working accuracy."""
        self.local(prev)
        return self._coincident

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


def _breakaway_between(bgains: NDArray, k0: float, k1: float) -> int | None:
    """Index of the breakaway gain nearest to ``k0`` strictly between ``k0`` and ``k1``."""
    lo, hi = min(k0, k1), max(k0, k1)
    inside = np.flatnonzero((bgains > lo) & (bgains < hi))
    if inside.size == 0:
        return None
    return int(inside[np.argmin(np.abs(bgains[inside] - k0))])


def _breakaway_near(bgains: NDArray, k0: float, k1: float) -> int | None:
    """Index of the breakaway gain nearest to ``k0`` within three times the step from ``k0``
    to ``k1`` on either side; ``None`` if there is none."""
    if bgains.size == 0:
        return None
    h = k1 - k0
    rel = (bgains - k0) / h if h != 0 else np.where(bgains == k0, 0.0, np.inf)
    near = np.flatnonzero((rel >= -3.0) & (rel <= 3.0))
    if near.size == 0:
        return None
    return int(near[np.argmin(np.abs(bgains[near] - k0))])


def _any_between(bgains: NDArray, k0: float, k1: float) -> bool:
    """Whether a breakaway gain lies in the closed interval from ``k0`` to ``k1``."""
    return bool(np.any((bgains >= min(k0, k1)) & (bgains <= max(k0, k1))))


def _shortens(k_new: float, k_cur: float, k_try: float) -> bool:
    """Whether a substep to ``k_new`` shortens the step from ``k_cur`` to ``k_try`` by more
    than round-off (an exact landing on a breakaway gain must not propose it again)."""
    return min(k_cur, k_try) < k_new < max(k_cur, k_try) and abs(k_new - k_cur) > 1e-9 * max(abs(k_new), 1e-300)


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


def _double_root_guess(tracker: _NewtonTracker, r2: NDArray, k_cur: float, k_try: float, k_b: float,
                       s_b: complex) -> NDArray:
    """Guesses at ``k_try`` for the two roots ``r2`` (at ``k_cur``) meeting at the double root
    ``s_b`` (gain ``k_b``): the local expansion ``s_b +- w``, ``w^2 = 2 L^2 (k - k_b) / L''``
    (from ``1/L(s) + k = 0`` with ``L'(s_b) = 0``). Each takes the sign nearest to its own
    offset from ``s_b``, turned by 90 degrees when the step crosses ``k_b``."""
    with np.errstate(all="ignore"):
        Lb, _, d2 = tracker.values(np.array([s_b], dtype=complex), second=True)
        w = np.sqrt(complex(2.0 * Lb[0] ** 2 * (k_try - k_b) / d2[0]))
    if not np.isfinite(w):
        return r2
    o = r2[0] - s_b
    if (k_try - k_b) * (k_cur - k_b) < 0:
        o = 1j * o
    sgn = 1.0 if (np.conj(w) * o).real >= 0 else -1.0
    return np.array([s_b + sgn * w, s_b - sgn * w])


def _siso_zeros(L: LinearSystem) -> NDArray[np.complex128]:
    """Zeros of a SISO loop from one standard eigenvalue problem of order ``n - rho``.

    ``d != 0``: the eigenvalues of ``A - b c / d``. ``d = 0``, relative degree ``rho``
    (``c A^j b = 0`` for ``j < rho - 1``, to round-off): the zero dynamics (output held at
    zero) ``N = (I - b (c A^(rho-1) b)^-1 c A^(rho-1)) A`` on its invariant subspace, the
    kernel of ``[c; c A; ...; c A^(rho-1)]`` (orthonormal basis ``Q`` from a QR
    factorization), so the zeros are ``eig(Q^T N Q)``. Used only when the rank-one term is
    at most 1e3 times ``A`` in norm, which keeps the errors at round-off of ``A``; otherwise,
    or for ``rho > 3``, the pencil reduction of :func:`_invariant_zeros`."""
    A, b, c, d = L.A, L.B[:, 0], L.C[0], float(L.D[0, 0])
    n = A.shape[0]
    normA = max(float(np.linalg.norm(A, 1)), 1e-300)
    nb = float(np.linalg.norm(b))
    if d != 0:
        if nb * float(np.linalg.norm(c)) <= 1e3 * normA * abs(d):
            return scipy.linalg.eigvals(A - np.outer(b, c) / d, check_finite=False)
        return _invariant_zeros(L.A, L.B, L.C, L.D)
    rows = [c]
    for _ in range(min(3, n)):
        g = float(rows[-1] @ b)
        if abs(g) > 1e-12 * nb * float(np.linalg.norm(rows[-1])):
            rho = len(rows)
            break
        rows.append(rows[-1] @ A)
    else:
        return _invariant_zeros(L.A, L.B, L.C, L.D)
    cA = rows[-1] @ A
    if rho >= n or nb * float(np.linalg.norm(cA)) > 1e3 * normA * abs(g):
        return _invariant_zeros(L.A, L.B, L.C, L.D)
    Q = np.linalg.qr(np.array(rows).T, mode="complete")[0][:, rho:]
    AQ = A @ Q
    N = Q.T @ AQ - np.outer(Q.T @ b, (cA @ Q) / g)
    return scipy.linalg.eigvals(N, check_finite=False)


def _breakaways(L: LinearSystem, sign: float, tracker: _NewtonTracker | None = None):
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
    if tracker is not None:
        # the modal form: O(n) per candidate instead of a dense solve
        with np.errstate(all="ignore"):
            Ls = tracker.values(cand)[0]
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


def root_locus(loop_or_sys, gains: ArrayLike | None = None, *, k_max: float | None = None, negative: bool = False,
               max_displacement: float = 0.25, breakaway: bool | None = None, max_steps: int = 5000,
               continuation: bool = True) -> RootLocus:
    """Closed-loop eigenvalues over the loop gain, with adaptive steps and branch matching.

    Parameters
    ----------
    loop_or_sys : Loop, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`Loop` (its loop transfer function at the plant input ``L = K P`` is used) or a
        square loop transfer function ``L``; the closed loop is ``u = -k y`` (negative feedback).
    gains : array_like, optional
        The gains to report [-] (inverse units of ``L``). Between consecutive given gains the tracker takes hidden substeps
        so that branch matching stays reliable. Default: an adaptive sequence from 0 to
        ``k_max`` (or ``-k_max`` with ``negative=True``).
    k_max : float, optional
        End of the automatic sequence [-]; default ``1e4 / |L(s0)|`` at a point ``s0`` of the
        spectral scale (far into the asymptotic regime).
    negative : bool, optional
        Trace the complementary locus (``k <= 0``) instead.
    max_displacement : float, optional
        Largest root movement per step relative to the local root spacing [-]: steps are halved
        above it and doubled below a quarter of it.
    breakaway : bool, optional
        Locate all breakaway/break-in points from a pencil eigenproblem of twice the order and
        put their gains in the sequence (SISO). Default: for an automatic sequence of a SISO
        loop up to 200 states. Otherwise the continuation locates the breakaways it meets
        (Newton on ``L'(s) = 0`` next to the roots that jumped) and reports those.
    max_steps : int, optional
        Limit on gain steps (eigenvalue solves plus continuation steps).
    continuation : bool, optional
        For SISO loops, move the roots from one gain to the next by Newton's method on
        ``1/L(s) + k`` in the modal form (O(n^2) per step) and fall back to a dense eigenvalue
        solve only when a step fails its checks (convergence, distinct roots, trace of the
        closed-loop matrix). ``False`` uses a dense eigenvalue solve at every gain.

    Returns
    -------
    RootLocus

    Raises
    ------
    ModelError
        If ``L`` is not square, or ``I + k D`` is singular at a requested gain.
    ShapeError
        If ``gains`` is not a 1-D array of finite numbers.

    Notes
    -----
    Reference notes section 10.2: each trial gain ``k_new = k rho`` is accepted when the
    matched roots moved less than ``max_displacement`` times their distance to the nearest
    other root (plus a floor at the root's own modulus), else ``rho`` is square-rooted; the
    matching is a linear assignment (``scipy.optimize.linear_sum_assignment``) on distances.
    Breakaway points are the zeros of ``L'(s)`` (a pencil of the cascade ``(sI - A)^-2``, no
    polynomial) where ``k = -1/L(s)`` is real with the sign of the locus.

    The continuation (SISO) evaluates ``L`` and its first three derivatives as Cauchy sums over
    the poles of the modal form (O(n) per root; a rigid-body multiple pole folded in as exact
    partial fractions), predicts each root along its branch (quintic Hermite from the last two
    gains with ``ds/dk = L^2 / L'`` and ``d2s/dk2``), corrects it by Halley's method and stops
    a root as soon as the error estimate of its last update, ``|K| |delta|^3``, is at round-off
    (most roots after one evaluation per gain), iterates only one root of each conjugate pair,
    and, for given gains, corrects up to 8 consecutive gains in one vectorized pass; every gain
    is checked as a single step would be (each root converged to round-off, all roots
    distinct, their sum equal to the trace, the displacement test), and the gains from the
    first failure on are taken one at a time. A double root at ``k_b`` (from the pencil, or
    located by Newton on ``L'(s) = 0`` next to the roots that jumped) is crossed in one step
    once its two roots are isolated near it: they are exempt from the displacement test (the
    others pass it and keep their identities; which of the two continues which branch is a
    convention, offsets turned by 90 degrees) and guessed from the local expansion
    ``s_b +- sqrt(2 L^2 (k - k_b) / L'')``; until then the substeps approach ``k_b``
    geometrically. Likewise the root through infinity at ``1 + k d = 0`` is exempt near that
    gain and guessed from the trace. A failed step is retried once from half the step (two
    roots passing close by); after three failures in a row, dense solves take over for a
    number of gains that doubles with each further failure. The first step leaves the poles
    from first-order guesses ``lambda - k r``. The zeros of a SISO loop come from one standard
    eigenproblem (``A - b c / d``, or the zero dynamics at relative degree up to 3).

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> L = LinearSystem([[0, 1], [0, -2]], [[0], [1]], [[1, 0]])     # 1/(s (s + 2))
    >>> rl = root_locus(L)
    >>> rl.breakaway_points.real.round(6).tolist(), rl.breakaway_gains.round(6).tolist()
    ([-1.0], [1.0])
    """
    t0 = time.perf_counter()
    L = loop_or_sys.open_loop() if isinstance(loop_or_sys, Loop) else as_linear_system(loop_or_sys, "loop_or_sys")
    if L.n_inputs != L.n_outputs:
        raise ModelError(f"the loop transfer function must be square, got {L.n_outputs} outputs and {L.n_inputs} inputs")
    if not 0 < max_displacement < 1:
        raise ModelError(f"max_displacement must be in (0, 1), got {max_displacement!r}")
    cl = _ClosedLoop(L)
    n = L.n_states
    siso = L.shape == (1, 1)
    tracker = None
    if siso and n and continuation:
        try:
            tracker = _NewtonTracker(L)
        except (ValueError, np.linalg.LinAlgError):
            tracker = None
    if tracker is not None:
        # the modal form's eigenvalues of (balanced) A: the open-loop solve is done there
        poles = tracker.poles
        cl.count += 1
    else:
        poles = cl.eig(0.0)
    scale = max(float(np.max(np.abs(poles))) if n else 0.0, 1e-12)
    s_ref = 1e-3 * max(scale, 1.0)
    zeros = (_siso_zeros(L) if siso else _invariant_zeros(L.A, L.B, L.C, L.D)) if n else np.zeros(0, dtype=complex)
    sign = -1.0 if negative else 1.0
    if breakaway is None:
        breakaway = siso and n <= 200 and gains is None
    n_newton = 0
    bpts, bgains = (_breakaways(L, sign, tracker) if (breakaway and siso and n)
                    else (np.zeros(0, complex), np.zeros(0)))

    _displacement = _Displacement(s_ref)
    # the gain where the loop is ill-posed (1 + k d = 0): a root passes through infinity
    d_loop = float(L.D[0, 0]) if siso else 0.0
    k_inf = np.array([-1.0 / d_loop]) if d_loop != 0 and tracker is not None else np.zeros(0)
    hints = [np.asarray(bgains, dtype=float), np.asarray(bpts, dtype=complex)]   # breakaways for the substeps
    accepted: list = []   # the last two accepted (gain, roots, ds/dk or None), for the predictor
    found = {}            # ds/dk and spacing of the last Newton result, by the identity of its roots

    def accept(k, r):
        info = found.get(id(r))
        if info is not None and info[0] is r:
            accepted.append((k, r, info[1]))
            if info[2] is not None:
                _displacement.local(r, info[2], info[3])
        else:
            accepted.append((k, r, None))
        found.clear()
        del accepted[:-2]

    health = {"fails": 0, "skip": 0, "rejected": 0}   # consecutive failures; gains left to skip

    def newton_usable():
        return tracker is not None and health["skip"] == 0

    def record(ok):
        # a loop where the continuation keeps failing (checks not met at most gains) is
        # cheaper with dense solves alone: after three failures in a row the continuation is
        # skipped for a number of gains that doubles with every further failure (up to 32)
        if ok:
            health["fails"] = 0
        else:
            health["fails"] += 1
            health["rejected"] += 1
            if health["fails"] >= 3:
                health["skip"] = min(32, 1 << (health["fails"] - 3))

    def solve_newton(k_cur, r_cur, k_try, pair=None, big=None):
        """``(roots, guess)``: roots at k_try in the order of r_cur by Newton continuation
        (``None`` when a check fails), and the prediction it started from."""
        nonlocal n_newton
        guess = r_cur
        if k_cur == 0:
            # leaving the open-loop poles: first-order guesses (a multiple pole by its local
            # model); the checks and the displacement test decide as for any other step
            guess = tracker.leave_poles(r_cur, k_try)
            if guess is None:
                return None, r_cur
        elif accepted and accepted[-1][0] == k_cur and accepted[-1][1] is r_cur:
            # predictor along the branches; Newton corrects it, the checks and the
            # displacement test reject a bad one (the roots away from a double root are
            # analytic in k across it, so the predictor holds for them there too)
            guess = _predict(accepted, k_try)
        prev, loose = r_cur, None
        if pair is not None:
            two, k_b, s_b = pair
            guess = guess.copy()
            guess[two] = _double_root_guess(tracker, r_cur[two], k_cur, k_try, k_b, s_b)
            if (k_try - k_b) * (k_cur - k_b) <= 0:
                # real roots turn into a conjugate pair or back: these two are iterated on
                # their own, the other conjugate pairs of r_cur carry over
                loose = two
        if big is not None:
            # the root through infinity (1 + k d = 0 at k_inf): from the trace of the
            # closed-loop matrix, A - k b c / (1 + k d), less the other roots' guesses
            guess = guess.copy()
            trace = tracker.traceA - k_try * tracker.cb / (1.0 + k_try * tracker.d.real)
            guess[big] = trace - (np.sum(guess) - guess[big])
        with np.errstate(all="ignore"):
            r_new = tracker.step(guess, k_try, prev, loose) if np.all(np.isfinite(guess)) else None
        record(r_new is not None)
        if r_new is not None:
            n_newton += 1
            found[id(r_new)] = (r_new, tracker.dsdk, tracker.spacing, tracker.coincident)
        return r_new, guess

    def solve_dense(r_cur, k_try):
        """Roots at k_try in the order of r_cur: dense eigenvalues and linear assignment."""
        if health["skip"]:
            health["skip"] -= 1
        r_new = _match(r_cur, cl.eig(k_try))
        if tracker is not None and k_try != 0:
            # the branch tangents at the dense solution, for the predictor of the next step
            with np.errstate(all="ignore"):
                dsdk = _tangents(*tracker.values(r_new, second=True))
            if np.all(np.isfinite(dsdk)):
                found[id(r_new)] = (r_new, dsdk, None, False)
        return r_new

    def add_hint(found_b):
        """Record a breakaway located by the continuation; False if none or already known
        (the caller then bisects instead of retrying: no step is retried without progress)."""
        if found_b is None:
            return False
        k_b = found_b[0]
        if np.any(np.abs(hints[0] - k_b) <= 1e-9 * abs(k_b)):
            return False
        hints[0] = np.append(hints[0], k_b)
        hints[1] = np.append(hints[1], found_b[1])
        return True

    def track(k_from, r_from, k_to):
        """Roots at k_to matched to r_from, with hidden substeps when the jump is too large."""
        nonlocal worst
        found.clear()
        pending = [k_to]
        k_cur, r_cur = k_from, r_from
        retried = None   # the gain of a substep proposed after a failed continuation step
        while pending:
            k_try = pending[-1]
            budget = (cl.count + n_newton) < max_steps
            pair = None
            b = _breakaway_near(hints[0], k_cur, k_try) if (n > 1 and k_cur != 0) else None
            if b is not None and budget:
                # a double root s_b at gain k_b inside the step or just behind it: the two roots
                # meeting there move like s_b +- a sqrt(k - k_b), too fast for the displacement
                # test near k_b. Once these two are the only roots near s_b (isolated: all others
                # at least twice as far), they are exempt from the test: the others pass it, so
                # every other root keeps its identity and the two left over are the pair (which
                # of the two continues which branch across k_b is a convention: offsets turned
                # by 90 degrees). Until then, approach k_b geometrically, k_b - 0.3 (k_b - k).
                k_b, s_b = hints[0][b], hints[1][b]
                two = _isolated_pair(r_cur, s_b)
                if two is not None:
                    pair = (two, k_b, s_b)
                else:
                    k_new = k_b - 0.3 * (k_b - k_cur)
                    if (k_try - k_b) * (k_cur - k_b) <= 0 and _shortens(k_new, k_cur, k_try):
                        pending.append(k_new)
                        k_try = k_new
            big = None
            if k_inf.size and n > 1 and _breakaway_near(k_inf, k_cur, k_try) is not None:
                # the gain where 1 + k d = 0 (a root through infinity) inside the step or
                # near it: the root of largest modulus is exempt from the displacement test
                # (its motion is unbounded there); the others pass it and keep their
                # identities, so the one left over is that root
                big = int(np.argmax(np.abs(r_cur)))
            r_try = None
            if newton_usable():
                r_try, guess = solve_newton(k_cur, r_cur, k_try, pair, big)
                if r_try is None and budget and pair is None and k_cur != 0:
                    # a double root ahead that is not known yet makes the iterates of the two
                    # roots meeting there collide: look for it next to the root predicted to
                    # move most (Newton on L'(s) = 0); else, once after continuation steps
                    # that passed, retry from half the step (an avoided crossing: two roots
                    # passing close by, turning faster than the predictor follows)
                    if _breakaway_near(hints[0], k_cur, k_try) is None:
                        found_b = tracker.local_breakaway(r_cur, guess, _displacement.local(r_cur), k_cur, k_try)
                        if add_hint(found_b):
                            continue
                    k_mid = 0.5 * (k_cur + k_try)
                    if health["fails"] == 1 and retried is None and _shortens(k_mid, k_cur, k_try):
                        retried = k_mid
                        pending.append(k_mid)
                        continue
            if r_try is None:
                r_try = solve_dense(r_cur, k_try)
            exempt = []
            ok_pair = True
            if pair is not None:
                two_new = _isolated_pair(r_try, pair[2])
                ok_pair = two_new is not None and set(two_new.tolist()) == set(pair[0].tolist())
                exempt.extend(pair[0].tolist())
            if big is not None and int(np.argmax(np.abs(r_try))) == big:
                exempt.append(big)
            d = _displacement(r_cur, r_try, exempt=np.array(exempt, dtype=int) if exempt else None) if ok_pair else np.inf
            if d > max_displacement and _shortens(0.5 * (k_cur + k_try), k_cur, k_try) and budget:
                if tracker is not None and k_cur != 0 and pair is None and _breakaway_near(hints[0], k_cur, k_try) is None:
                    # a breakaway the pencil did not give (not computed, or missed): look for
                    # a double root next to the root that moved most, by Newton on L'(s) = 0
                    found_b = tracker.local_breakaway(r_cur, r_try, _displacement.local(r_cur), k_cur, k_try, ahead=3.0)
                    if add_hint(found_b):
                        continue
                # from the open loop (dense eig only) shrink geometrically: roots leave a
                # multiple pole like k^(1/m), so halving alone would need many dense solves
                pending.append(k_try * 1e-3 if k_cur == 0 else 0.5 * (k_cur + k_try))
                continue
            worst = max(worst, d)
            pending.pop()
            k_cur, r_cur = k_try, r_try
            accept(k_cur, r_cur)
        return r_cur

    worst = 0.0
    if gains is not None:
        try:
            g = np.array(gains, dtype=float)
        except (TypeError, ValueError) as err:
            raise ShapeError(f"gains must be an array of real numbers: {err}") from err
        if g.ndim != 1 or g.size == 0:
            raise ShapeError(f"gains must be a non-empty 1-D array, got shape {g.shape}")
        if not np.all(np.isfinite(g)):
            raise ShapeError(f"gains[{int(np.argmax(~np.isfinite(g)))}] is not finite")
        g = np.sort(g)
        rows = [poles if g[0] == 0 else cl.eig(g[0])]
        # start from the open loop when 0 lies before the first gain, to order branches by pole
        if g[0] != 0 and n:
            rows[0] = track(0.0, poles, g[0]) if g[0] > 0 or g[-1] <= 0 else rows[0]
        i, block = 1, 4
        while i < len(g):
            k_prev, r_prev = g[i - 1], rows[-1]
            G = min(block, len(g) - i, max_steps - (cl.count + n_newton))
            ks = g[i:i + G]
            if (newton_usable() and health["fails"] == 0 and G >= 2 and k_prev != 0 and np.all(ks * k_prev > 0) and len(accepted) == 2
                    and accepted[-1][1] is r_prev and accepted[0][2] is not None and accepted[1][2] is not None
                    and not _any_between(hints[0], accepted[0][0], ks[-1])
                    and _breakaway_near(k_inf, k_prev, ks[-1]) is None):
                # several requested gains at once: predicted along the branches, corrected by
                # one vectorized Newton iteration, then each checked like a single step
                # (convergence, distinct roots, trace, displacement from the row before); the
                # rows up to the first failure are kept, the rest goes through track()
                S, dS, spacing, coincident, ok = tracker.step_many(_predict(accepted, ks[:, None]), ks, r_prev)
                # the displacement test of every row against the row before, at once (the
                # local spacing of a row from its Newton spacing, as _Displacement.local)
                loc = np.empty((G, n))
                loc[0] = _displacement.local(r_prev)
                np.minimum(spacing[:-1], np.abs(S[:-1]) + s_ref, out=loc[1:])
                loc[1:] += s_ref
                step_d = np.abs(np.diff(S, axis=0, prepend=r_prev[None]))
                step_d /= loc
                d = np.max(step_d, axis=1) if n else np.zeros(G)
                good = ok & (d <= max_displacement)
                n_ok = G if good.all() else int(np.argmin(good))
                if n_ok:
                    new_rows = [S[j] for j in range(n_ok)]
                    rows.extend(new_rows)
                    n_newton += n_ok
                    worst = max(worst, float(np.max(d[:n_ok])))
                    last = new_rows[-1]
                    tracker.remember(r_prev, last)
                    if n_ok >= 2:
                        accepted[:] = [(ks[n_ok - 2], new_rows[-2], dS[n_ok - 2])]
                    accepted.append((ks[n_ok - 1], last, dS[n_ok - 1]))
                    del accepted[:-2]
                    _displacement.local(last, spacing[n_ok - 1], bool(coincident[n_ok - 1]))
                i += n_ok
                block = min(2 * block, 8) if n_ok == G else max(2, n_ok)
                if n_ok:
                    continue
            rows.append(track(k_prev, r_prev, g[i]))
            i += 1
        out_g = g
    else:
        if k_max is None:
            z = np.concatenate([poles, zeros])
            s0 = max(float(np.max(np.abs(z))) if z.size else 1.0, 1e-6) * (0.73 + 0.41j)
            G = L.D + L.C @ np.linalg.solve(s0 * np.eye(n) - L.A, L.B) if n else L.D
            gmag = float(np.max(np.abs(G)))
            k_max = 1e4 / gmag if gmag > 0 else 1e4
        k_max = float(abs(k_max))
        if not np.isfinite(k_max) or k_max <= 0:
            raise ModelError(f"k_max must be a positive finite gain, got {k_max!r}")
        forced = sorted(abs(b) for b in bgains if abs(b) < k_max)
        k = 0.0
        r = poles
        out_g, rows = [0.0], [poles]
        step = k_max * 1e-8
        while k < k_max and cl.count + n_newton < max_steps:
            k_next = min(k + step if k == 0 else max(k * (1 + step / max(k, 1e-300)), k + step), k_max)
            if forced and k < forced[0] <= k_next:
                k_next = forced.pop(0)
            r_try = None
            if newton_usable() and k != 0:
                r_try, _ = solve_newton(sign * k, r, sign * k_next)
            if r_try is None:
                r_try = solve_dense(r, sign * k_next)
            d = _displacement(r, r_try)
            if d > max_displacement and k_next - k > 1e-10 * k_next and cl.count + n_newton < max_steps:
                step = 0.5 * (k_next - k)
                continue
            worst = max(worst, d)
            k, r = k_next, r_try
            accept(sign * k, r)
            out_g.append(k)
            rows.append(r)
            if forced and forced[0] <= k:
                forced.pop(0)
            step = (k_next - (out_g[-2] if len(out_g) > 1 else 0.0)) * (2.0 if d < max_displacement / 4 else 1.0)
        out_g = sign * np.array(out_g)
    roots = np.array(rows, dtype=complex).reshape(len(out_g), n)
    if len(hints[0]) > len(bgains):
        # the breakaways the continuation located itself
        order = np.argsort(np.abs(hints[0]), kind="stable")
        bpts, bgains = hints[1][order], hints[0][order]
    arrays = [np.asarray(out_g, dtype=float), roots, poles, zeros, bpts, bgains]
    for a in arrays:
        a.setflags(write=False)
    return RootLocus(
        gains=arrays[0], roots=roots, open_loop_poles=poles, open_loop_zeros=zeros, breakaway_points=bpts,
        breakaway_gains=bgains, max_step_displacement=worst, n_eigenvalue_solves=cl.count,
        n_continuation_steps=n_newton, n_rejected_continuation_steps=health["rejected"],
        seconds=time.perf_counter() - t0,
    )

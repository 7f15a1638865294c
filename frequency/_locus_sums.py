"""``L(s)`` of a SISO loop and its derivatives at many points, from its modal form (root locus).

The evaluator behind the root-locus continuation (:mod:`._locus_tracker`): partial fractions
over the poles, conjugate pairs folded into real second-order terms, a defective block (the
rigid body's double pole) as exact multiple-pole terms or, failing that, by a triangular solve.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem
from linflex.system import complex_schur

from ._evaluate import _Modal, _Unstructured
from ._modal_forms import _BlockModal, block_components


class _NoContinuation(Exception):
    """The loop has no modal form the continuation can use (the caller takes dense solves)."""


# the largest loop whose whole Schur form is evaluated as one triangular block (O(n^3) per
# point by the Neumann series of the block): beyond it, dense eigenvalue solves are cheaper
_SCHUR_MAX = 20


def _cancellation(lam: NDArray, r: NDArray) -> float:
    """Largest ratio of ``sum |r_i / (s - lambda_i)|`` to ``|sum r_i / (s - lambda_i)|`` at
    eight points of radius 1 and twice the spectral radius: the factor the partial fractions
    lose to cancellation. Large for a multiple pole that round-off split into close simple
    poles with large opposite residues (``A`` of ``1/s^2`` with entries of 1e-16 where zeros
    belong, balanced: poles at +-6e-9, residues +-8e7, a cancellation of 1e8 at ``|s| = 1``),
    about ``|s|`` over the spectral scale for a loop of relative degree 2."""
    if not lam.size:
        return 1.0
    radius = max(1.0, 2.0 * float(np.max(np.abs(lam))))
    s = np.r_[1.0, radius][:, None] * np.exp(1j * np.array([0.4, 1.3, 1.9, 2.7]))[None, :]
    terms = r[None, :] / (s.reshape(-1, 1) - lam[None, :])
    total = np.abs(terms.sum(axis=1))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(terms).sum(axis=1) / total
    return float(np.max(np.where(total > 0, ratio, np.inf)))


def structured_modal(L: LinearSystem) -> _BlockModal | None:
    """The block-wise modal form of ``L`` when its ``A`` has blocks (and hub states) that
    :func:`~._modal_forms.block_components` finds, else ``None``: O(n) per point instead of the
    dense form's O(n^3) set-up."""
    blocks = block_components(L.A)
    if blocks is None:
        return None
    try:
        return _BlockModal(L, blocks)
    except (_Unstructured, np.linalg.LinAlgError, ValueError):
        return None


class _LoopSums:
    """``L(s)`` of a SISO loop and its first three derivatives at many points, O(n) per point.

    ``L(s) = d + sum_i r_i / (s - lambda_i) + C1 (sI - T11)^-1 B1`` from the block-diagonal
    modal form of :class:`._response._Modal` (the small block holds the ill-conditioned,
    typically defective, eigenvalues). When no eigenvalue is well conditioned (``1/s^n``,
    ``1/(s + a)^2``: the modal form has nothing to separate), or the partial fractions would
    lose more than ``1e5 eps`` to cancellation (:func:`_cancellation`), the block is the whole
    complex Schur form of ``A`` (unitary, so well conditioned) with no diagonal part, for loops
    up to ``_SCHUR_MAX`` states. The block is then folded into exact partial fractions where it
    can be (:meth:`_fold_block`) and the conjugate pairs into real terms (:meth:`_fold_pairs`).

    Raises :class:`_NoContinuation` when a mode has no residue (uncontrollable or unobservable:
    not a root of ``1 + k L``), the modal form is too ill-conditioned, or a larger loop has no
    accurate modal form.
    """

    def __init__(self, L: LinearSystem) -> None:
        self.d = complex(L.D[0, 0])
        self.modal = self.pole_estimate = None
        m = structured_modal(L)
        if m is None:
            try:
                m = _Modal(L)
            except (_Unstructured, np.linalg.LinAlgError, ValueError):
                m = None
        if m is not None and _cancellation(m.lam, m.K[:, 0]) > 1e5:
            m = None   # the partial fractions would lose more than 1e5 eps to cancellation
        if m is None and L.n_states > _SCHUR_MAX:
            raise _NoContinuation("no modal form that evaluates L accurately")
        if m is not None:
            self.lam = np.ascontiguousarray(m.lam)
            self.r = np.ascontiguousarray(m.K[:, 0])
            self.k_block = m.k
            if m.k:
                T11, B1, C1 = m.T11, m.B1[:, 0], m.C1[0]
                if isinstance(m, _BlockModal):
                    # the blocks' dense part as it is (ill-conditioned blocks, a hub): its
                    # complex Schur form, the triangular block the sums expect
                    T11, Z = scipy.linalg.schur(T11, output="complex", check_finite=False)
                    B1, C1 = Z.conj().T @ B1, C1 @ Z
            self.cond = float(m.cond)
            self.poles = np.asarray(m.poles, dtype=complex)
            if isinstance(m, _BlockModal):
                # the block-wise form: the closed-loop roots at a gain and the zeros come from
                # the Aberth iteration on its sums (:mod:`._modal_roots`), the open-loop poles'
                # estimates from its blocks
                self.modal, self.pole_estimate = m, m.pole_estimate
        else:
            # unbalanced: balancing a split multiple pole (off-diagonal entries 1 and eps)
            # scales b and c apart by 1/sqrt(eps), which the triangular solves would then cancel
            T11, Z, _ = complex_schur(np.asarray(L.A, dtype=float))
            B1, C1 = (Z.conj().T @ L.B)[:, 0], (L.C @ Z)[0]
            self.lam = np.zeros(0, dtype=complex)
            self.r = np.zeros(0, dtype=complex)
            self.k_block = L.n_states
            self.cond = 1.0
            self.poles = np.diag(T11).copy()
        if self.k_block:
            self.T11, self.B1, self.C1 = T11, B1, C1
            self._tdiag = np.diag(T11).copy()
            self._NT = np.triu(T11, 1).T.copy()
        scale_r = np.abs(self.r)
        if scale_r.size and np.min(scale_r) <= 1e-13 * np.max(scale_r):
            # a mode the loop cannot move (uncontrollable or unobservable): not a root of 1 + kL
            raise _NoContinuation("a mode with zero residue")
        if self.cond > 1e8:
            raise _NoContinuation("modal form too ill-conditioned for continuation")
        self._multi: list = []
        if self.k_block:
            self._fold_block()
        self._fold_pairs()

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
            beyond: dict = {}   # column -> {(derivative j, power of w beyond o + 1): coefficient}
            for j, b, col, f in powers:
                if j > o:
                    continue
                if b <= o + 1:
                    add(co, j, b, 0, col, f)
                else:
                    beyond.setdefault(col, {})[(j, b - (o + 1))] = f
            # per column: the terms (j, e, f), out[j] += f w^(o + 1 + e), and as a matrix E
            extras = []
            for col, terms in beyond.items():
                E = np.zeros((o + 1, 1 + max(e for _, e in terms)))
                for (j, e), f in terms.items():
                    E[j, e] += f
                extras.append((col, [(j, e, f) for (j, e), f in terms.items()], E))
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
            _add_powers(out, S[order * nf:], W, extras)
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
            _add_powers(out[:, i0:i1], Wp, W, extras)

    def values(self, s, second: bool = False, third: bool = False):
        """``L(s)`` and ``L'(s)`` at the points ``s``, then ``L''(s)`` with ``second=True`` and
        also the third derivative with ``third=True``: an array of shape (order + 1, len(s))."""
        order = 3 if third else (2 if second else 1)
        out = np.empty((order + 1, len(s)), dtype=complex)
        if not len(s):
            return out
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



def _add_powers(out: NDArray, last: NDArray, W: NDArray, extras: list) -> None:
    """Add the powers of ``w`` beyond ``order + 1`` (multiple poles) to ``out``: per column
    ``t`` of the folded terms, ``out[j] += sum_e E[j, e] w_t^(order + 1 + e)``, from the row
    ``last[t] = w_t^(order + 1)``: a few terms one by one, many (a pole of high multiplicity)
    by repeated products and one small matrix product."""
    for t, terms, E in extras:
        if len(terms) <= 2:
            # a few terms (the rigid body's double pole: one): directly, no work arrays
            for j, e, f in terms:
                x = last[t] * f
                for _ in range(e):
                    x *= W[t]
                out[j] += x
            continue
        V = np.empty((E.shape[1], out.shape[1]), dtype=complex)
        V[0] = last[t]
        for e in range(1, E.shape[1]):
            np.multiply(V[e - 1], W[t], out=V[e])
        out += E @ V


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



"""Fast evaluation of a state-space transfer matrix on the imaginary axis.

``G(jw) = C (jw I - A)^-1 B + D`` is evaluated at many frequencies after one O(n^3)
factorization of ``A``:

0. diagonal balancing of ``A`` (``scipy.linalg.matrix_balance``, a similarity);
1. real Schur form ``A = Z T Z^T`` ordered so that the rigid-body cluster (``|lambda| <= tol``)
   comes first;
2. the Sylvester equation ``T11 X - X T22 = -T12`` decouples the cluster from the rest
   (``W^-1 T W = diag(T11, T22)`` with ``W = [[I, X], [0, I]]``):

   ::

       [ T11  T12 ]   ->   [ T11   0  ]      T11: rigid-body block (k x k, small)
       [  0   T22 ]        [  0   T22 ]      T22: everything else

3. ``T22 = V diag(mu) V^-1`` when ``V`` is well conditioned (the "modal" path, O(n) per
   frequency); otherwise a complex Schur form of ``T22`` and one triangular solve per frequency
   (the "schur" path, O(n^2) per frequency);
4. the small rigid block is solved directly at each frequency.

A Jordan block at the origin (a double integrator) has no eigenvector basis, which is why it is
split off before the eigen-decomposition. The accuracy of the fast path is checked against dense
complex solves ``numpy.linalg.solve(jw I - A, B)`` at a few frequencies by :meth:`check`.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex.system import diagonal_balance, schur_eigenvalues

from ._common import rigid_mask

__all__ = ["TransferEvaluator"]

#: Largest condition number of the eigenvector matrix for which the modal path is used.
MODAL_COND_MAX = 1e8


class TransferEvaluator:
    """``G(jw)`` of a state-space system at any frequencies (see the module docstring).

    Parameters
    ----------
    A, B, C, D : ndarray
        Real system matrices.
    rigid_tol : float or None
        Tolerance for the rigid-body cluster split off first (see
        :func:`~linflex.stability._common.rigid_mask`; None for the default rule).
    split_rigid : bool
        False to split off nothing (for closed loops, which have no rigid-body poles when
        stable).
    """

    def __init__(self, A, B, C, D, rigid_tol: float | None = None, *, split_rigid: bool = True) -> None:
        A = np.asarray(A, dtype=float)
        B = np.asarray(B, dtype=float)
        C = np.asarray(C, dtype=float)
        self.A, self.B, self.C = A, B, C
        self.D = np.asarray(D, dtype=float)
        self.n_evaluations = 0
        n = A.shape[0]
        p, m = self.D.shape
        self.shape = (p, m)
        self.k = 0
        self.path = "static"
        if n == 0:
            self.poles = np.zeros(0, complex)
            return
        # diagonal balancing first (a similarity, G(s) unchanged) when it pays: states of very
        # different units would otherwise spoil the Schur form. Skipped when it does not reduce
        # the norm tenfold, because balancing also blows up rounding-level entries (1e-17 left
        # in A by a transfer-function conversion) by scale factors up to 1e16.
        Ab, Bb, Cb, _ = diagonal_balance(A, B, C)
        self.balanced = bool(np.linalg.norm(Ab, 1) < 0.1 * np.linalg.norm(A, 1))
        if self.balanced:
            A, B, C = Ab, Bb, Cb
        # the rigid group is decided on the eigenvalues of this very Schur computation, so that
        # the sorted second call (same input, same algorithm) puts exactly that group first
        cluster = -1.0
        if split_rigid:
            T0 = scipy.linalg.schur(A, output="real")[0]
            eig0 = schur_eigenvalues(T0)
            rigid, _ = rigid_mask(eig0, A, rigid_tol)
            if rigid.any():
                # smaller non-rigid eigenvalues, if any, join the cluster (solved directly)
                # (slack: LAPACK hands the sort callable its own rounding of the same values)
                cluster = float(np.abs(eig0[rigid]).max()) * (1 + 1e-6) + np.finfo(float).tiny
        T, Z, k = scipy.linalg.schur(A, output="real", sort=lambda re, im: np.hypot(re, im) <= cluster)
        Bt, Ct = Z.T @ B, C @ Z
        self.k = k = int(k)
        if 0 < k < n:
            X = scipy.linalg.solve_sylvester(T[:k, :k], -T[k:, k:], -T[:k, k:])
            B1, C1 = Bt[:k] - X @ Bt[k:], Ct[:, :k]
            B2, C2 = Bt[k:], Ct[:, :k] @ X + Ct[:, k:]
        else:
            B1, C1 = Bt[:k], Ct[:, :k]
            B2, C2 = Bt[k:], Ct[:, k:]
        self.T11, self.B1, self.C1 = T[:k, :k], B1, C1
        T22 = T[k:, k:]
        poles = [np.linalg.eigvals(self.T11)] if k else []
        self.path = "modal"
        self.T22, self.B2, self.C2 = T22, B2, C2
        self._tri = None
        self.n_fallback = 0
        if n - k:
            mu, V = scipy.linalg.eig(T22)
            poles.append(mu)
            cond = np.linalg.cond(V) if mu.size else 1.0
            if np.isfinite(cond) and cond < MODAL_COND_MAX:
                Cm = C2 @ V
                Bm = np.linalg.solve(V, B2)
                # residues R[k] = Cm[:, k] Bm[k, :], flattened to (n2, p*m) for one matmul
                self.mu = mu
                self.R = (Cm.T[:, :, None] * Bm[:, None, :]).reshape(mu.size, p * m)
                # rounding bound of the modal sum: eps * cond(V) * sum_k |R_k| / |s - mu_k|
                self.absR = np.abs(self.R) * (4 * np.finfo(float).eps * max(cond, 1.0))
            else:
                self.path = "schur"
        else:
            self.mu = np.zeros(0, complex)
            self.R = self.absR = np.zeros((0, p * m))
        self.poles = np.concatenate(poles) if poles else np.zeros(0, complex)
        if k and self.path == "modal" and n - k == 0:
            self.path = "rigid"

    def _triangular(self, s: NDArray[np.complex128]) -> NDArray[np.complex128]:
        """``C2 (s I - T22)^-1 B2`` by one triangular solve per frequency (complex Schur form)."""
        if self._tri is None:
            Tc, Zc = scipy.linalg.schur(self.T22.astype(complex), output="complex")
            self._tri = (Tc, Zc.conj().T @ self.B2, self.C2 @ Zc)
            self._work = -Tc  # s I - Tc, only the diagonal changes with s
        Tc, Bc, Cc = self._tri
        M = self._work
        p, m = self.shape
        out = np.empty((s.size, p, m), complex)
        idx = np.arange(Tc.shape[0])
        d0 = -np.diag(Tc)
        for i, si in enumerate(s):
            M[idx, idx] = d0 + si
            out[i] = Cc @ scipy.linalg.solve_triangular(M, Bc, check_finite=False)
        return out

    def __call__(self, omega) -> NDArray[np.complex128]:
        """``G(j omega)`` with shape ``(n_omega, p, m)`` for ``omega`` [rad/s] (1-D)."""
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        # blocks of frequencies keep the (n_omega, n) work arrays in cache
        block = max(64, 2**18 // max(self.A.shape[0], 1))
        if w.size > block:
            return np.concatenate([self._evaluate(w[i:i + block]) for i in range(0, w.size, block)])
        return self._evaluate(w)

    def at(self, s) -> NDArray[np.complex128]:
        """``G(s)`` at complex points ``s`` [1/s] (1-D), shape ``(n_s, p, m)``."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        block = max(64, 2**18 // max(self.A.shape[0], 1))
        return np.concatenate([self._evaluate(s[i:i + block] / 1j) for i in range(0, max(s.size, 1), block)])

    def _evaluate(self, w: NDArray) -> NDArray[np.complex128]:
        # w may be complex (s / j) when called through at()
        s = 1j * w
        p, m = self.shape
        self.n_evaluations += w.size
        out = np.broadcast_to(self.D.astype(complex), (w.size, p, m)).copy()
        if self.path == "static":
            return out
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.k:
                k = self.k
                M = s[:, None, None] * np.eye(k) - self.T11[None, :, :]
                X = np.linalg.solve(M, np.broadcast_to(self.B1.astype(complex), (w.size, k, m)))
                out += self.C1 @ X
            if self.path == "modal" and self.mu.size:
                G = 1.0 / (s[:, None] - self.mu[None, :])
                if p * m == 1:
                    # elementwise products instead of matrix-vector products: no BLAS threads
                    # to start for a (n_omega, n) x (n, 1) product
                    part = (G * self.R[:, 0]).sum(axis=1).reshape(w.size, 1, 1)
                    bound = (np.abs(G) * self.absR[:, 0]).sum(axis=1)
                else:
                    part = (G @ self.R).reshape(w.size, p, m)
                    bound = (np.abs(G) @ self.absR).max(axis=1)
                # where the modal sum cancels (large residues, small result), redo by triangular
                # solves: flag rows whose rounding bound exceeds 1e-10 of the result
                size = np.abs(part).reshape(w.size, -1).max(axis=1)
                bad = ~(bound <= 1e-10 * size)
                if bad.any() and self.T22.shape[0]:
                    part[bad] = self._triangular(s[bad])
                    self.n_fallback += int(bad.sum())
                out += part
            elif self.path == "schur":
                out += self._triangular(s)
        return out

    def siso(self, omega) -> NDArray[np.complex128]:
        """``G(j omega)`` for a 1x1 system, as a 1-D array."""
        return self(omega)[:, 0, 0]

    def direct(self, omega: float) -> NDArray[np.complex128]:
        """Reference value by a dense complex solve ``C (jw I - A)^-1 B + D`` (O(n^3))."""
        n = self.A.shape[0]
        if n == 0:
            return self.D.astype(complex)
        X = np.linalg.solve(1j * omega * np.eye(n) - self.A, self.B.astype(complex))
        return self.C @ X + self.D

    def check(self, omega, floor: float = 0.0) -> float:
        """Largest difference between the fast path and dense solves at ``omega``, relative to
        ``max(||G||, floor)`` (a floor keeps a vanishing reference, ``S(0) = 0`` of a loop with
        an integrator, from turning rounding into a large relative error)."""
        err = 0.0
        for w in np.atleast_1d(omega):
            ref = self.direct(float(w))
            fast = self(np.array([w]))[0]
            scale = max(np.linalg.norm(ref), floor, np.finfo(float).tiny)
            if np.all(np.isfinite(ref)) and np.all(np.isfinite(fast)):
                err = max(err, float(np.linalg.norm(fast - ref) / scale))
        return err

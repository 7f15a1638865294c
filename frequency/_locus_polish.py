"""The last step of the root locus: every reported root polished, and its error estimated.

A dense eigenvalue solve of the closed-loop matrix ``A - k B (I + k D)^-1 C`` is backward stable
for *that matrix*, whose norm can exceed ``||A||`` by orders of magnitude at a high gain: its
roots are then off by ``eps ||A_cl|| cond`` (measured: 2e-7 relative on a 27-state loop under
PD control at gain 1.2e6, ``||A_cl|| = 1.6e9`` against ``||A|| = 1.3e6``). The closed-loop poles
are the zeros of ``det(I + k G(s))``, ``G(s) = C (sI - A)^-1 B + D``, whose evaluation only
perturbs ``A``: Newton's method on that determinant, with ``G`` from the complex Schur form of
the balanced ``A`` (:func:`~._spectrum.joint_balance`; unitary, so backward stable), moves each
root to the accuracy of the loop itself.

Error estimate of a root ``s`` (a-posteriori, [1/s]): the last Newton step plus the movement
that the evaluation error can cause, ``n eps (||A|| + |s|) ||Y|| ||X|| / |u^H Y X v|`` (``X = (sI -
A)^-1 B``, ``Y = C (sI - A)^-1``, ``u, v`` the singular vectors of the smallest singular value of
``I + k G(s)``: the root's condition number for perturbations of ``A``). A root that Newton's
method does not take (a multiple root, a mode the loop does not see, a step that would reach
another root) keeps its eigenvalue; its estimate is the first Newton step times the number of
roots within four such steps (a q-fold root is q Newton steps away), or, where ``G`` cannot be
evaluated there, ``n eps ||A_cl|| cond`` of the dense eigenvalue.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.spatial
from numpy.typing import NDArray

from linflex import LinearSystem
from linflex.system import complex_schur

from ._spectrum import EPS, joint_balance

__all__ = ["polish_roots"]

#: Newton steps per root (from a backward-stable eigenvalue, quadratic convergence reaches
#: round-off in two).
_STEPS = 3
#: Largest move of a polished root relative to the distance to the nearest other root.
_MAX_MOVE = 0.25
#: Relative error estimate above which a continuation root is polished on the Schur form too.
_POOR = 1e-8
#: Rows of the triangular solves of :meth:`_SchurLoop.solves` taken as one block.
_SOLVE_BLOCK = 64
#: Shifts evaluated in one vectorized pass (memory: chunk * n * m complex numbers).
_CHUNK = 4096
#: Up to this order every root of a dense row is polished. Above it a dense row's roots are first
#: estimated from the closed loop's left and right eigenvectors (one eigendecomposition, BLAS-3)
#: and only those worse than ``_POOR`` are polished: Newton's method costs O(n^2) per root and step
#: in substitutions one row at a time (3.1 of the 3.2 s of a 100-gain locus at order 401).
_POLISH_ALL_MAX = 100


class _SchurLoop:
    """``X = (sI - T)^-1 B'`` and ``Y = C' (sI - T)^-1`` at many shifts, ``T`` the complex Schur
    form of the balanced ``A`` (``A = Z T Z^H``, ``B' = Z^H B``, ``C' = C Z``), computed on
    first use (O(n^3): a locus whose rows all come from the modal sums never needs it)."""

    def __init__(self, L: LinearSystem) -> None:
        A, B, C = (np.asarray(x, dtype=float) for x in (L.A, L.B, L.C))
        t = joint_balance(A, B, C)
        A, B, C = A * (1.0 / t)[:, None] * t[None, :], B * (1.0 / t)[:, None], C * t[None, :]
        self.n = A.shape[0]
        self.D = np.asarray(L.D, dtype=float)
        self.normA = float(np.linalg.norm(A, "fro"))
        self.balanced = (A, B, C)
        self._form = None

    def _schur(self):
        if self._form is None:
            A, B, C = self.balanced
            T, Z, _ = complex_schur(A)
            self._form = (T, Z.conj().T @ B, C @ Z)
        return self._form

    T = property(lambda self: self._schur()[0])
    B = property(lambda self: self._schur()[1])
    C = property(lambda self: self._schur()[2])

    def solves(self, s: NDArray[np.complex128]):
        """``(X, Y)`` of shapes (p, n, m) and (p, m, n) at the shifts ``s`` (p,): back and forward
        substitution for all shifts at once (shifts and channels side by side), in blocks of
        ``_SOLVE_BLOCK`` rows: the solved rows enter a block as one matrix product, then row by
        row inside it."""
        T, B, C = self.T, self.B, self.C
        n, m, q = T.shape[0], B.shape[1], C.shape[0]
        p = s.size
        X = np.zeros((n, p, m), dtype=complex)
        Y = np.zeros((n, p, q), dtype=complex)
        d = s[None, :] - np.diag(T)[:, None]        # (n, p)
        TT = np.ascontiguousarray(T.T)
        Xf, Yf = X.reshape(n, p * m), Y.reshape(n, p * q)
        nb = _SOLVE_BLOCK
        with np.errstate(all="ignore"):
            # (BLAS-3: the solved part is read once per block instead of once per row)
            for e in range(n, 0, -nb):
                b = max(0, e - nb)
                R = np.broadcast_to(B[b:e][:, None, :], (e - b, p, m)).reshape(e - b, p * m).copy()
                if e < n:
                    R += T[b:e, e:] @ Xf[e:]
                for i in range(e - 1, b - 1, -1):
                    rhs = R[i - b] + T[i, i + 1:e] @ Xf[i + 1:e]
                    Xf[i] = (rhs.reshape(p, m) / d[i][:, None]).reshape(p * m)
            for b in range(0, n, nb):
                e = min(n, b + nb)
                R = np.broadcast_to(C[:, b:e].T[:, None, :], (e - b, p, q)).reshape(e - b, p * q).copy()
                if b > 0:
                    R += TT[b:e, :b] @ Yf[:b]
                for i in range(b, e):
                    rhs = R[i - b] + TT[i, b:i] @ Yf[b:i]
                    Yf[i] = (rhs.reshape(p, q) / d[i][:, None]).reshape(p * q)
        return X.transpose(1, 0, 2), Y.transpose(1, 2, 0)


def _newton_steps(ev: _SchurLoop, s: NDArray[np.complex128], k: NDArray[np.float64]):
    """Newton step on ``det(I + k G(s))`` at each shift and the evaluation error bound of the root."""
    X, Y = ev.solves(s)
    m = ev.D.shape[0]
    G = np.einsum("mj,pjq->pmq", ev.C, X) + ev.D[None]
    kk = k[:, None, None]
    F = np.eye(m)[None] + kk * G
    dG = -np.einsum("pmj,pjq->pmq", Y, X)     # G'(s) = -C (sI - A)^-2 B
    with np.errstate(all="ignore"):
        ok = np.all(np.isfinite(F), axis=(1, 2)) & np.all(np.isfinite(dG), axis=(1, 2))
        step = np.full(s.size, np.nan + 0j)
        bound = np.full(s.size, np.inf)
        if np.any(ok):
            Fo, dGo, ko = F[ok], dG[ok], kk[ok]
            # det'/det = tr(F^-1 k G') = sum_i (U^H k G' V)_ii / sigma_i (F = U S V^H): finite
            # however nearly singular F is at the root; a step of 0 where F is exactly singular
            U, sig, Vh = np.linalg.svd(Fo)
            kdG = ko * dGo
            W = np.einsum("pim,pmq,pqi->pi", U.conj(), kdG, Vh.conj().transpose(0, 2, 1))
            slope = np.abs(W[:, -1])
            exact = sig[:, -1] == 0
            tr = np.sum(W / np.where(sig > 0, sig, 1.0), axis=1)
            step[ok] = np.where(exact, 0.0, -1.0 / tr)
            nX = np.linalg.norm(X[ok], axis=(1, 2))
            nY = np.linalg.norm(Y[ok], axis=(1, 2))
            n = ev.n
            # sI - T perturbed by eps (||A|| + |s|)
            bound[ok] = n * EPS * (ev.normA + np.abs(s[ok])) * np.abs(ko[:, 0, 0]) * nX * nY / slope
    return step, bound


def polish_roots(L: LinearSystem, gains: NDArray[np.float64], roots: NDArray[np.complex128],
                 dense: NDArray[np.bool_], tracker=None):
    """Roots (n_gains, n) [1/s] and their error estimates [1/s] (see the module docstring).

    The rows ``dense`` (from dense eigenvalue solves) are polished by Newton's method on the
    Schur form; the others come from the continuation, converged on the modal sums of
    ``tracker`` already, and are only estimated there (:func:`_continuation_estimates`: O(n)
    per root, where the Schur form costs O(n^2)). Rows at ``k = 0`` are the open-loop poles:
    their estimate is ``n eps ||A|| cond(lambda)``."""
    roots = np.array(roots, dtype=complex)
    est = np.full(roots.shape, np.inf)
    n = roots.shape[1] if roots.ndim == 2 else 0
    if n == 0 or roots.shape[0] == 0:
        return roots, est
    gains = np.asarray(gains, dtype=float)
    dense = np.asarray(dense, dtype=bool) | (gains == 0) | (tracker is None)
    ev = _SchurLoop(L)
    if np.any(dense) and n <= _POLISH_ALL_MAX:
        roots[dense], est[dense] = _schur_polish(ev, gains[dense], roots[dense])
    elif np.any(dense):
        # the open-loop rows (k = 0) are left to _dense_estimates (the blocks' estimates when
        # the tracker has a block-wise modal form)
        rows = np.flatnonzero(dense & (gains != 0))
        e = np.array([_eig_estimates(ev, gains[i], roots[i]) for i in rows]).reshape(rows.size, n)
        est[rows] = _polish_poor(ev, gains[rows], roots, rows, e)
    if not np.all(dense):
        cont = np.flatnonzero(~dense)
        e = _continuation_estimates(tracker, ev, gains[cont], roots[cont])
        if getattr(tracker, "modal", None) is None:
            # a continuation root the modal sums leave worse than 1e-8 relative (an ill-conditioned
            # modal form) is polished on the Schur form as well, the rest of its row left as it
            # is; a block-wise modal form: no O(n^3) Schur form for a second opinion, the roots
            # keep the estimates of the sums they converged on
            e = _polish_poor(ev, gains[cont], roots, cont, e)
        est[cont] = e
    _dense_estimates(ev, gains, roots, est, tracker)
    return roots, est


def _polish_poor(ev: _SchurLoop, gains, roots, rows, e) -> NDArray[np.float64]:
    """Polish on the Schur form the roots of ``roots[rows]`` (in place) whose estimates ``e``
    exceed ``_POOR`` relative, keeping a polished root only where its estimate is smaller;
    returns the estimates."""
    poor = ~(e <= _POOR * np.maximum(1.0, np.abs(roots[rows])))
    some = np.flatnonzero(poor.any(axis=1))
    if some.size:
        r2, e2 = _schur_polish(ev, gains[some], roots[rows[some]], select=poor[some])
        take = poor[some] & (e2 < e[some])
        sub = roots[rows[some]]
        sub[take] = r2[take]
        roots[rows[some]] = sub
        es = e[some]
        es[take] = e2[take]
        e[some] = es
    return e


def _eig_estimates(ev: _SchurLoop, k: float, row) -> NDArray[np.float64]:
    """Error estimates [1/s] of the roots ``row`` of a dense row at gain ``k``: ``n eps ||A_cl||_F
    cond(lambda)`` of the nearest eigenvalue of the balanced closed loop (left and right
    eigenvectors), plus the root's distance to it; inf where the eigenproblem fails."""
    A, B, C = ev.balanced
    n, m = A.shape[0], B.shape[1]
    out = np.full(row.shape, np.inf)
    fin = np.isfinite(row)
    try:
        Acl = A - k * B @ np.linalg.solve(np.eye(m) + k * ev.D, C) if k else A
        lam, vl, vr = scipy.linalg.eig(Acl, left=True, right=True, check_finite=False)
    except (np.linalg.LinAlgError, ValueError):
        return out
    if not fin.any() or not np.all(np.isfinite(lam)):
        return out
    with np.errstate(divide="ignore"):
        cond = 1.0 / np.abs(np.sum(vl.conj() * vr, axis=0))
    e = n * EPS * float(np.linalg.norm(Acl, "fro")) * cond
    dist, q = scipy.spatial.cKDTree(_points(lam)).query(_points(row[fin]))
    out[fin] = np.maximum(e[q], dist)
    return out


def _continuation_estimates(tracker, ev: _SchurLoop, gains, roots) -> NDArray[np.float64]:
    """Error estimates [1/s] of roots the continuation converged on the modal sums: the Newton
    step ``L (1 + k L) / L'`` left at the root plus the evaluation error of the sums over
    ``|L'|``: ``4 n eps (||A|| cond + |s|)`` (the modal form's condition; ``s - lambda`` rounded)
    times the sensitivity of ``L``
    to its poles, ``sum |r_i| / |s - lambda_i|^2`` (and ``(j + 1) |a_j| / |s - mu|^(j+2)`` for
    a multiple pole's terms), plus ``n eps sum |r_i / (s - lambda_i)|`` for the sums' own
    rounding."""
    s = roots.ravel()
    k = np.broadcast_to(gains[:, None], roots.shape).ravel()
    n = ev.n
    out = np.full(s.size, np.inf)
    lower = _lower_partners(roots).ravel()
    j = np.flatnonzero(np.isfinite(s) & ~lower)
    for c in range(0, j.size, _CHUNK):
        i = j[c:c + _CHUNK]
        si, ki = s[i], k[i]
        with np.errstate(all="ignore"):
            Lr, dL = tracker.values(si)
            step = np.abs(Lr * (1.0 + ki * Lr) / dL)
            # 1 / |s - lambda|^2 in real arithmetic, the sums as matrix-vector products
            w2 = np.subtract.outer(si.real, tracker.lam.real)
            w2 *= w2
            dy = np.subtract.outer(si.imag, tracker.lam.imag)
            dy *= dy
            w2 += dy
            np.reciprocal(w2, out=w2)
            ar = np.abs(tracker.r)
            sens = w2 @ ar
            size = np.sqrt(w2, out=w2) @ ar + abs(tracker.d)
            for mu, coef, _ in tracker._multi:
                wm = 1.0 / np.abs(si - mu)
                for p, a in enumerate(coef, start=1):
                    sens += (p + 1) * abs(a) * wm ** (p + 2)
                    size += abs(a) * wm ** (p + 1)
            if tracker.k_block:
                Q = 1.0 / np.subtract.outer(si, tracker._tdiag)
                X = tracker._block_solve(Q, tracker.B1)
                X2 = tracker._block_solve(Q, X)
                sens += np.abs(X2) @ np.abs(tracker.C1)
                size += np.abs(X) @ np.abs(tracker.C1)
            # a pole perturbed by eps ||A|| cond (the modal form), and s - lambda rounded by
            # eps |s| (it dominates beyond the spectral scale, at high gain)
            # (4 n: each of the n terms carries a few roundings, the folded pair's q, its power
            # and the product with the residue)
            err_L = 4 * n * EPS * ((ev.normA * tracker.cond + np.abs(si)) * sens + size)
            e = step + err_L / np.abs(dL)
        out[i] = np.where(np.isfinite(e), e, np.inf)
    out = out.reshape(roots.shape)
    _mirror_estimates(roots, out)
    return out


def _schur_polish(ev: _SchurLoop, gains, roots, select=None):
    """Newton's method on the Schur form for the rows ``roots`` at ``gains`` (only the roots
    ``select`` when given, the others with an infinite estimate): ``(roots, est)``."""
    n = roots.shape[1]
    K = np.broadcast_to(gains[:, None], roots.shape)
    s0 = roots.ravel()
    k = K.ravel()
    # the lower root of an exact conjugate pair is not iterated: it mirrors its partner
    lower = _lower_partners(roots)
    if select is not None:
        # a selected lower root is iterated through its partner
        sel = np.asarray(select, dtype=bool)
        for i, j in zip(*np.nonzero(sel & lower)):
            sel[i, np.flatnonzero(roots[i] == roots[i, j].conj())] = True
        lower = lower | ~sel
    live = np.isfinite(s0) & (k != 0) & ~lower.ravel()
    # distance of each root to the nearest other root of its row (k-d trees: O(n log n))
    trees = [_tree(r) for r in roots]
    near = np.full(roots.shape, np.inf)
    if n > 1:
        for i, (tree, fin) in enumerate(trees):
            if tree is not None and fin.sum() > 1:
                dist, _ = tree.query(_points(roots[i][fin]), k=2)
                near[i, fin] = dist[:, 1]
    near = near.ravel()
    s = s0.copy()
    first = np.full(s0.size, np.nan + 0j)
    last = np.full(s0.size, np.inf)
    prev = np.full(s0.size, np.inf)
    bound = np.full(s0.size, np.inf)
    ok = live.copy()
    done = np.zeros(s0.size, bool)
    for it in range(_STEPS):
        act = np.flatnonzero(ok)
        if not act.size:
            break
        for c in range(0, act.size, _CHUNK):
            j = act[c:c + _CHUNK]
            step, b = _newton_steps(ev, s[j], k[j])
            if it == 0:
                first[j] = step
            prev[j], last[j], bound[j] = last[j], np.abs(step), b
            good = np.isfinite(step)
            s[j[good]] += step[good]
            ok[j[~good]] = False
        ok &= np.abs(s - s0) <= _MAX_MOVE * near
        with np.errstate(invalid="ignore"):
            # the step is at the evaluation's accuracy, or the second of two steps shrank
            # quadratically (never on the first step alone: next to a near pole-zero
            # cancellation a first step can be large and wrong)
            converged = ok & ((last <= 10 * (bound + 4 * EPS * np.abs(s)))
                              | (np.isfinite(prev) & (last <= 1e-2 * prev) & (last <= 1e-6 * np.abs(s))))
        done |= converged   # at round-off: no further step (a continuation root needs one)
        ok &= ~done
    converged = done
    out = np.where(converged, s, s0)
    # conjugate pairs stay exact conjugates, real roots real (A, B, C, D are real)
    out = out.reshape(roots.shape)
    conv = converged.reshape(roots.shape)
    est_flat = np.where(converged, last + bound, np.inf)
    # roots Newton did not take: the first step times the roots within four steps
    f = np.abs(first)
    cluster = np.ones(roots.shape)
    fr = f.reshape(roots.shape)
    for i, (tree, fin) in enumerate(trees):
        want = fin & np.isfinite(fr[i]) & ~conv[i]
        if tree is not None and want.any():
            hits = tree.query_ball_point(_points(roots[i][want]), 4 * fr[i][want], return_length=True)
            cluster[i, want] = np.maximum(hits, 1)
    fallback = np.where(np.isfinite(f), cluster.ravel() * f + bound, np.inf)
    est_flat = np.where(converged, est_flat, fallback)
    est = est_flat.reshape(roots.shape)
    _mirror(roots, out, est, conv)
    return out, est


def _points(z):
    return np.column_stack([z.real, z.imag])


def _tree(row):
    """A k-d tree of the finite roots of a row, and their mask."""
    fin = np.isfinite(row)
    return (scipy.spatial.cKDTree(_points(row[fin])) if fin.any() else None), fin


def _mirror_estimates(roots, est) -> None:
    """The lower root of an exact conjugate pair takes its partner's estimate."""
    for i in range(roots.shape[0]):
        r = roots[i]
        neg = np.flatnonzero(r.imag < 0)
        pos = np.flatnonzero(r.imag > 0)
        if not neg.size or not pos.size:
            continue
        d = np.abs(r[neg][:, None] - r[pos][None, :].conj())
        q = np.argmin(d, axis=1)
        exact = d[np.arange(neg.size), q] == 0
        est[i, neg[exact]] = est[i, pos[q[exact]]]


def _lower_partners(roots) -> NDArray[np.bool_]:
    """The roots with ``Im < 0`` whose exact conjugate is in the same row."""
    lower = np.zeros(roots.shape, bool)
    for i in range(roots.shape[0]):
        r = roots[i]
        neg = np.flatnonzero(r.imag < 0)
        if neg.size:
            lower[i, neg] = np.isin(r[neg].conj(), r[r.imag > 0])
    return lower


def _mirror(roots, out, est, conv) -> None:
    """Make the roots of each row conjugate-symmetric as the eigenvalues were: a root with
    ``Im < 0`` takes the conjugate of its partner's polished value, a real root stays real."""
    for i in range(roots.shape[0]):
        r = roots[i]
        real = r.imag == 0
        out[i, real] = out[i, real].real
        neg = np.flatnonzero(r.imag < 0)
        pos = np.flatnonzero(r.imag > 0)
        if not neg.size or not pos.size:
            continue
        d = np.abs(r[neg][:, None] - r[pos][None, :].conj())
        partner = pos[np.argmin(d, axis=1)]
        exact = d[np.arange(neg.size), np.argmin(d, axis=1)] == 0
        a, b = neg[exact], partner[exact]
        out[i, a] = out[i, b].conj()
        est[i, a] = est[i, b]


def _dense_estimates(ev: _SchurLoop, gains, out, est, tracker=None) -> None:
    """Rows with a root Newton's method could not evaluate (``k = 0``, a pole the loop does not
    see): ``n eps ||A_cl|| cond(lambda)`` from the closed-loop eigenvectors (balanced); at
    ``k = 0`` with a block-wise modal form (``tracker.pole_estimate``), the same from the
    blocks' eigenvectors (no dense eigenproblem)."""
    for i in np.flatnonzero(np.any(~np.isfinite(est) & np.isfinite(out), axis=1)):
        k = float(gains[i])
        if k == 0 and getattr(tracker, "pole_estimate", None) is not None:
            bad = np.flatnonzero(~np.isfinite(est[i]) & np.isfinite(out[i]))
            poles = tracker.poles
            for j in bad:
                q = int(np.argmin(np.abs(poles - out[i, j])))
                est[i, j] = max(float(tracker.pole_estimate[q]), float(np.abs(poles[q] - out[i, j])))
            continue
        bad = ~np.isfinite(est[i]) & np.isfinite(out[i])
        est[i, bad] = _eig_estimates(ev, k, out[i])[bad]

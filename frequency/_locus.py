"""Root locus: closed-loop eigenvalues over a scalar loop gain, tracked branch by branch."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

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
        Loop gains, monotone (increasing for ``k >= 0``, decreasing for the complementary
        locus); the first is 0 for an automatic sequence.
    roots : numpy.ndarray of complex, shape (n_gains, n_states)
        ``roots[:, j]`` is branch ``j``: consecutive rows are matched by minimum total
        displacement (linear assignment), so a branch is a continuous curve [1/s].
    open_loop_poles, open_loop_zeros : numpy.ndarray of complex
        Start and (finite) end points of the branches.
    breakaway_points : numpy.ndarray of complex
        Points where two branches meet and leave (SISO loops; empty otherwise or when not
        computed): double roots of ``1 + k L(s)``.
    breakaway_gains : numpy.ndarray
        The gains at those points (real, of the sign of the locus).
    max_step_displacement : float
        Largest accepted root displacement between consecutive gains, relative to the local
        root spacing; the matching is reliable when this is well below 0.5.
    n_eigenvalue_solves : int
        Dense eigenvalue solves.
    n_continuation_steps : int
        Gain steps taken by Newton continuation instead.
    seconds : float
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
    seconds: float

    @property
    def branches(self) -> list[NDArray[np.complex128]]:
        """The branches as a list of arrays of shape (n_gains,)."""
        return [self.roots[:, j] for j in range(self.roots.shape[1])]

    def plot(self, **kwargs):
        """Root-locus plot: see :func:`linflex.frequency.root_locus_plot`."""
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
    scaled both near the poles (small gains) and near the zeros (large gains). A step is
    rejected (and the caller falls back to a dense eigenvalue solve) unless every root
    converged, the roots are distinct, and their sum equals the trace of the closed-loop matrix.
    """

    def __init__(self, L: LinearSystem) -> None:
        from ._response import _Modal

        m = _Modal(L)
        self.lam = m.lam
        self.r = m.K[:, 0]
        self.d = complex(L.D[0, 0])
        self.k_block = m.k
        if m.k:
            self.T11, self.B1, self.C1 = m.T11, m.B1[:, 0], m.C1[0]
        self.cond = m.cond
        self.traceA = float(np.trace(L.A))
        self.cb = float((L.C @ L.B)[0, 0])
        scale_r = np.abs(self.r)
        if scale_r.size and np.min(scale_r) <= 1e-13 * np.max(scale_r):
            # a mode the loop cannot move (uncontrollable or unobservable): not a root of 1 + kL
            raise ValueError("a mode with zero residue")
        if self.cond > 1e8:
            raise ValueError("modal form too ill-conditioned for continuation")

    def values(self, s):
        R = 1.0 / (s[:, None] - self.lam[None, :])
        Rr = R * self.r[None, :]
        Lr = self.d + Rr.sum(axis=1)
        dL = -(Rr * R).sum(axis=1)
        if self.k_block:
            # T11 is upper triangular (complex Schur form): back substitution for all s at
            # once, twice, for (sI - T11)^-1 B1 and (sI - T11)^-2 B1
            X = self._tri_solve(s, np.broadcast_to(self.B1, (len(s), self.k_block)))
            X2 = self._tri_solve(s, X)
            Lr = Lr + X @ self.C1
            dL = dL - X2 @ self.C1
        return Lr, dL

    def _tri_solve(self, s, rhs):
        T, kb = self.T11, self.k_block
        X = np.empty((len(s), kb), dtype=complex)
        for i in range(kb - 1, -1, -1):
            acc = rhs[:, i] + X[:, i + 1:] @ T[i, i + 1:]
            X[:, i] = acc / (s - T[i, i])
        return X

    def step(self, r0: NDArray, k: float) -> NDArray | None:
        s = r0.astype(complex).copy()
        n = len(s)
        with np.errstate(all="ignore"):
            active = np.arange(n)
            for _ in range(12):
                sa = s[active]
                Lr, dL = self.values(sa)
                res = 1.0 + k * Lr
                delta = Lr * res / dL
                s[active] = sa + delta
                # |k L| = 1 at a root, so |1 + k L| is a relative residual; with quadratic
                # convergence an update at round-off level leaves the root exact to round-off
                done = (np.abs(res) <= 1e-13) | (np.abs(delta) <= 1e-13 * np.maximum(1.0, np.abs(sa)))
                active = active[~done]
                if active.size == 0:
                    break
            else:
                return None
        if not np.all(np.isfinite(s)):
            return None
        if n > 1:
            # two iterates on one root are neighbours in the order by (real, imaginary)
            o = np.lexsort((s.imag, s.real))
            gaps = np.abs(np.diff(s[o]))
            if np.min(gaps) <= 1e-7 * max(1.0, float(np.max(np.abs(s)))):
                return None
        trace = self.traceA - k * self.cb / (1.0 + k * self.d.real)
        if abs(np.sum(s).real - trace) > 1e-8 * max(1.0, float(np.sum(np.abs(s)))) or abs(np.sum(s).imag) > 1e-8 * max(
                1.0, float(np.sum(np.abs(s)))):
            return None
        return s


def _match(prev: NDArray, new: NDArray) -> NDArray:
    cost = np.abs(prev[:, None] - new[None, :])
    r, c = linear_sum_assignment(cost)
    out = np.empty_like(new)
    out[r] = new[c]
    return out


def _displacement(prev: NDArray, new: NDArray, s_ref: float) -> float:
    """Largest root movement relative to the distance to the nearest other distinct root.

    Roots that coincide to working accuracy (repeated roots, e.g. identical axes of a MIMO loop)
    are not each other's neighbours: exchanging them changes nothing, and counting their zero
    spacing would stall the gain steps."""
    n = len(prev)
    if n == 0:
        return 0.0
    same = 1e-6 * max(1.0, float(np.max(np.abs(prev))))
    if n > 1:
        pts = np.column_stack([prev.real, prev.imag])
        kk = min(n, 12)
        dist, _ = cKDTree(pts).query(pts, k=kk)
        dist = dist[:, 1:]
        dist = np.where(dist <= same, np.inf, dist)
        spacing = np.min(dist, axis=1)
    else:
        spacing = np.full(1, np.inf)
    local = np.minimum(spacing, np.abs(prev) + s_ref) + s_ref
    return float(np.max(np.abs(new - prev) / local))


def _breakaways(L: LinearSystem, sign: float):
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
    pts, gains = [], []
    for s in cand:
        M = s * np.eye(n) - A
        try:
            Ls = d[0, 0] + (c @ np.linalg.solve(M, b))[0, 0]
        except np.linalg.LinAlgError:
            continue
        if Ls == 0:
            continue
        k = -1.0 / Ls
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
        The gains to report. Between consecutive given gains the tracker takes hidden substeps
        so that branch matching stays reliable. Default: an adaptive sequence from 0 to
        ``k_max`` (or ``-k_max`` with ``negative=True``).
    k_max : float, optional
        End of the automatic sequence; default ``1e4 / |L(s0)|`` at a point ``s0`` of the
        spectral scale (far into the asymptotic regime).
    negative : bool, optional
        Trace the complementary locus (``k <= 0``) instead.
    max_displacement : float, optional
        Largest root movement per step relative to the local root spacing: steps are halved
        above it and doubled below a quarter of it.
    breakaway : bool, optional
        Locate breakaway/break-in points and put their gains in the sequence (SISO). Default:
        for SISO loops up to 200 states (a pencil eigenproblem of twice the order).
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
    poles = cl.eig(0.0)
    scale = max(float(np.max(np.abs(poles))) if n else 0.0, 1e-12)
    s_ref = 1e-3 * max(scale, 1.0)
    zeros = _invariant_zeros(L.A, L.B, L.C, L.D) if n else np.zeros(0, dtype=complex)
    sign = -1.0 if negative else 1.0
    siso = L.shape == (1, 1)
    if breakaway is None:
        breakaway = siso and n <= 200
    bpts, bgains = (_breakaways(L, sign) if (breakaway and siso and n) else (np.zeros(0, complex), np.zeros(0)))

    tracker = None
    if siso and n and continuation:
        try:
            tracker = _NewtonTracker(L)
        except (ValueError, np.linalg.LinAlgError):
            tracker = None
    n_newton = 0

    accepted: list = []   # the last two accepted (gain, roots), for the secant predictor

    def accept(k, r):
        accepted.append((k, r))
        del accepted[:-2]

    def solve(k_cur, r_cur, k_try):
        """Roots at k_try in the order of r_cur: Newton continuation, else eig + assignment."""
        nonlocal n_newton
        if tracker is not None and k_cur != 0:
            guess = r_cur
            if len(accepted) == 2 and accepted[1][0] == k_cur and accepted[0][0] != k_cur:
                # secant predictor along the branches; Newton corrects it, the checks and the
                # displacement test reject a bad one
                (k0, r0), (k1, r1) = accepted
                guess = r1 + (r1 - r0) * ((k_try - k1) / (k1 - k0))
            r_new = tracker.step(guess, k_try)
            if r_new is not None:
                n_newton += 1
                return r_new
        return _match(r_cur, cl.eig(k_try))

    def track(k_from, r_from, k_to):
        """Roots at k_to matched to r_from, with hidden substeps when the jump is too large."""
        nonlocal worst
        pending = [k_to]
        k_cur, r_cur = k_from, r_from
        while pending:
            k_try = pending[-1]
            r_try = solve(k_cur, r_cur, k_try)
            d = _displacement(r_cur, r_try, s_ref)
            if d > max_displacement and abs(k_try - k_cur) > 1e-9 * max(abs(k_try), 1e-300) and (
                    cl.count + n_newton) < max_steps:
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
        for k_prev, k in zip(g[:-1], g[1:]):
            rows.append(track(k_prev, rows[-1], k))
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
            r_try = solve(sign * k, r, sign * k_next)
            d = _displacement(r, r_try, s_ref)
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
    arrays = [np.asarray(out_g, dtype=float), roots, poles, zeros, bpts, bgains]
    for a in arrays:
        a.setflags(write=False)
    return RootLocus(
        gains=arrays[0], roots=roots, open_loop_poles=poles, open_loop_zeros=zeros, breakaway_points=bpts,
        breakaway_gains=bgains, max_step_displacement=worst, n_eigenvalue_solves=cl.count,
        n_continuation_steps=n_newton,
        seconds=time.perf_counter() - t0,
    )

"""The H-infinity norm ``||G||_inf = sup_w sigma_max(G(jw))`` of a linear system, with a bound on the truth.

Three ways, chosen by :func:`hinf_norm` (``method="auto"``):

- ``"interval"``: on the engine's modal form (:class:`~._modal_forms._Modal`, or
  :class:`~._modal_forms._BlockModal` for a block-diagonal ``A``, dense or sparse: O(n) per
  point, no ``n x n`` matrix), a branch and bound over frequency intervals. On an interval
  ``[c - h, c + h]`` the resolvent identity, used twice, gives exactly ::

      G(jw) = G(jc) + (w - c) G'(c) - (w - c)^2 C R(jw) R(jc)^2 B,       R(s) = (sI - A)^-1

  and ``sigma_max(G(jc) + t G'(c))`` is convex in ``t``, so its largest value on the interval is
  at ``t = +-h``; the last term is bounded term by term of the modal sum, ``sum_i |K_i| /
  (|jc - lambda_i|^2 dist(lambda_i, interval))`` (the distance to the segment is exact), and
  for the split-off dense block by ``||C_1|| ||R_1(jw)|| ||R_1(jc)^2 B_1||`` with ``||R_1(jw)||
  <= r / (1 - h r)``, ``r = ||R_1(jc)||_F`` (Neumann series). Intervals whose bound exceeds
  ``(1 + rtol)`` times the largest value found are halved; above the last interval the tail
  ``sigma_max(D) + sum_i |K_i| / (W - |lambda_i|)`` closes the axis. The bound is
  second-order in ``h``: near a peak of damping ratio ``zeta`` intervals of width about
  ``sqrt(rtol) zeta w`` suffice. Every bound adds the evaluator's a-posteriori estimate at the
  interval's centre (the modal rounding and the inherent conditioning, see ``_evaluate.py``).
  The largest value found is finally polished by a bounded scalar search within its interval.
- ``"hamiltonian"``: a dense pole-aware sweep, local refinement and the Hamiltonian test
  (Bruinsma and Steinbuch, 1990; Boyd and Balakrishnan, 1990) at ``value (1 + 2 rtol)``: an
  eigenvalue problem of order ``2n``, for dense systems up to ``CERTIFY_MAX_STATES``.
- otherwise the sweep and refinement alone: a value attained, no upper bound.

The pole grid and the refinement (:func:`pole_grid`, :func:`top_maxima`, :func:`refined`) are
shared with the measured errors of :mod:`linflex.linearize`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError
from linflex.system import complex_schur, from_w_frequency

from ._checks import checked_system
from ._evaluate import SPARSE_POLES_MAX, TransferEvaluator
from ._modal_forms import _BlockModal, _Modal, _Unstructured
from ._sampled import engine_system
from ._spectrum import EPS, Spectrum, classify

__all__ = ["HinfNorm", "hinf_norm", "hinf_norm_stable", "pole_grid", "top_maxima", "refined",
           "CERTIFY_MAX_STATES", "HINF_METHODS", "hamiltonian_peak"]

#: Largest state count for which the Hamiltonian certificate (an eigenvalue problem of twice that
#: size) is computed; above it a dense system without a usable modal form gets a lower bound.
CERTIFY_MAX_STATES = 500
#: Methods of :func:`hinf_norm`.
HINF_METHODS = ("auto", "interval", "hamiltonian")
#: Largest split-off dense block of a modal form that the interval method takes (one small
#: inverse per point).
INTERVAL_DENSE_MAX = 200
#: Intervals halved per round of the branch and bound (evaluated together).
_BATCH = 1024


@dataclass(frozen=True)
class HinfNorm:
    """An H-infinity norm ``sup_w sigma_max(G(jw))`` with a bound on the truth.

    Attributes
    ----------
    value : float
        The largest singular value found [output units per input unit]; attained at ``omega``
        (a lower bound of the norm, to within ``evaluation_error``). ``inf`` for a system with a
        pole on or right of the imaginary axis.
    omega : float
        Frequency [rad/s] where ``value`` is attained (``inf`` when it is the high-frequency
        limit ``sigma_max(D)``; for a discrete system, ``pi / dt`` then).
    certified : bool
        True when the norm is known to lie in ``[value, value (1 + 2 rtol)]``.
    rtol : float
        Relative accuracy asked for.
    n_evaluations : int
        Number of frequency points evaluated.
    method : str
        How it was obtained.
    seconds : float
        Wall time [s].
    evaluation_error : float
        A-posteriori bound [output units per input unit] of the error of the evaluation behind
        ``value`` (the one evaluator of :mod:`linflex.frequency`). ``certified`` requires it below
        ``rtol * value``.
    upper : float
        An upper bound of the norm [output units per input unit]: ``value (1 + 2 rtol)`` when
        certified by the Hamiltonian test, the largest interval bound when found by intervals
        (finite even when the evaluation budget ran out before ``rtol`` was reached), ``inf``
        when no bound was computed.
    """

    value: float
    omega: float
    certified: bool
    rtol: float
    n_evaluations: int
    method: str
    seconds: float
    evaluation_error: float = 0.0
    upper: float = math.inf

    def __str__(self) -> str:
        where = "as w -> inf" if math.isinf(self.omega) else f"at {self.omega:.6g} rad/s"
        if math.isinf(self.value):
            return f"||G||_inf = inf ({self.method})"
        state = (f"certified to {self.rtol:.1g}" if self.certified
                 else f"not certified; upper bound {self.upper:.6g}")
        return f"||G||_inf = {self.value:.8g} {where} ({state}; {self.method}; {self.seconds:.3g} s)"


def hinf_norm(sys, *, rtol: float = 1e-6, method: str = "auto", max_evaluations: int = 200_000) -> HinfNorm:
    """The H-infinity norm of a linear system, with an upper bound on it.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem, control.StateSpace, control.TransferFunction, \
scipy.signal.lti or tuple
        The system, continuous or discrete (the norm over the unit circle, through the exact
        w-plane map), with or without input and output delays (they leave every singular value
        unchanged on the axis). A ``scipy.sparse`` ``A`` is kept sparse.
    rtol : float
        Relative accuracy [-] of the certificate, in ``(0, 0.1]``.
    method : {"auto", "interval", "hamiltonian"}
        See the module docstring. ``"auto"``: intervals on the modal form when there is one
        (block-diagonal or diagonalizable ``A``), else the Hamiltonian test up to
        ``CERTIFY_MAX_STATES`` states, else a sweep without certificate.
    max_evaluations : int
        Budget of frequency points for the interval method; when it runs out the result carries
        the upper bound reached and is not certified.

    Returns
    -------
    HinfNorm
        ``value`` (attained), ``upper`` (a bound) and how they were found.

    Raises
    ------
    ModelError
        For a system linflex cannot read, a bad ``method`` or ``rtol``, a sparse ``A`` without
        block structure above ``SPARSE_POLES_MAX`` states (its poles are not computed), or
        ``method="interval"`` on a system without a usable modal form.
    ShapeError
        For a system without inputs or outputs, or non-finite entries.

    Notes
    -----
    A pole on or right of the imaginary axis (by the rounding rule of the spectrum policy,
    :meth:`~linflex.frequency._spectrum.Spectrum.count_unstable`) gives ``value = inf``: the
    system is not in H-infinity (a double integrator, an undamped mode, an unstable loop).

    Examples
    --------
    A mode at 2 rad/s with damping ratio 0.01: the peak ``1 / (2 zeta sqrt(1 - zeta^2))``.

    >>> from linflex.frequency import hinf_norm
    >>> res = hinf_norm(([4.0], [1.0, 0.04, 4.0]))
    >>> round(res.value, 4), res.certified, res.upper <= res.value * (1 + 2e-6)
    (50.0025, True, True)
    """
    t0 = time.perf_counter()
    if method not in HINF_METHODS:
        raise ModelError(f"method must be one of {list(HINF_METHODS)}, got {method!r}")
    if not (isinstance(rtol, (int, float, np.integer, np.floating)) and not isinstance(rtol, bool) and 0 < rtol <= 0.1):
        raise ModelError(f"rtol must be a number in (0, 0.1], got {rtol!r}")
    if not (isinstance(max_evaluations, (int, np.integer)) and max_evaluations >= 1):
        raise ModelError(f"max_evaluations must be a positive integer, got {max_evaluations!r}")
    lin = checked_system(sys, "sys", discrete=True, delay=True)
    eng = engine_system(lin)
    res = _engine_norm(eng, float(rtol), method, int(max_evaluations), t0)
    if lin.is_discrete:
        w = math.pi / lin.dt if math.isinf(res.omega) else float(from_w_frequency(res.omega, lin.dt))
        res = dataclasses.replace(res, omega=w, method=res.method + " (on the w-plane image)")
    return res


def _engine_norm(sys: LinearSystem, rtol: float, method: str, budget: int, t0: float) -> HinfNorm:
    D = np.asarray(sys.D, dtype=float)
    if sys.n_states == 0:
        val = float(np.linalg.norm(D, 2))
        return HinfNorm(val, math.inf, True, rtol, 0, "static gain", time.perf_counter() - t0, 0.0, val)
    ev = TransferEvaluator(sys)
    modal = ev.modal
    if modal is None and sys.is_sparse and sys.n_states <= SPARSE_POLES_MAX:
        try:
            modal = _Modal(sys)   # a sparse A without blocks: its dense modal form, poles included
        except (_Unstructured, np.linalg.LinAlgError, ValueError):
            modal = None
    try:
        poles = modal.poles if modal is not None else ev.poles
    except ModelError as err:
        raise ModelError(f"hinf_norm: {err}") from None
    if sys.is_sparse:
        scale = float(getattr(modal, "normA", 0.0)) or float(abs(sys.A_sparse).sum(axis=0).max())
        spec = Spectrum(poles=poles, scale=scale, rigid=np.zeros(poles.size, bool), axis=np.zeros(poles.size, bool),
                        rigid_radius=0.0, rigid_tol=None)
    else:
        spec = classify(sys.A, poles=poles, B=sys.B, C=sys.C, D=D)
    if spec.count_unstable(poles):
        i = int(np.argmax(poles.real))
        return HinfNorm(math.inf, float(abs(poles[i].imag)), True, rtol, 0,
                        f"unstable: a pole at {complex(poles[i]):.6g} is not in the open left half-plane",
                        time.perf_counter() - t0, 0.0, math.inf)
    usable = isinstance(modal, _Modal) and modal.k <= INTERVAL_DENSE_MAX
    if method == "interval" and not usable:
        raise ModelError("method='interval' needs a modal form (a diagonalizable or block-diagonal A with a "
                         f"split-off block of at most {INTERVAL_DENSE_MAX} states); use method='hamiltonian'")
    if method in ("auto", "interval") and usable:
        return _interval_norm(modal, rtol, budget, t0)
    if sys.is_sparse and sys.n_states > CERTIFY_MAX_STATES and method == "auto":
        raise ModelError(f"hinf_norm: this sparse system of {sys.n_states} states has no usable modal form (its "
                         f"dense one split off more than {INTERVAL_DENSE_MAX} ill-conditioned states) and is above "
                         f"CERTIFY_MAX_STATES = {CERTIFY_MAX_STATES}; method='hamiltonian' takes an eigenvalue "
                         f"problem of order {2 * sys.n_states}")
    limit = sys.n_states if method == "hamiltonian" else CERTIFY_MAX_STATES
    res = hinf_norm_stable(sys.A, sys.B, sys.C, D, rtol=rtol, certify_max_states=limit)
    return dataclasses.replace(res, seconds=time.perf_counter() - t0)


def _interval_norm(modal, rtol: float, budget: int, t0: float) -> HinfNorm:
    """Branch and bound over frequency intervals on a modal form (module docstring)."""
    p, m = modal.shape
    lam = modal.lam
    K = modal.K
    Knorm = np.linalg.norm(K, axis=1)          # |c_i| |w_i b|: each term is rank one
    D = modal.D
    k = modal.k
    if k:
        T11, B1, C1 = modal.T11, modal.B1, modal.C1
        nC1 = float(np.linalg.norm(C1, 2))
        nT11 = float(np.linalg.norm(T11, 2))
        nB1 = float(np.linalg.norm(B1, 2))
    count = [0]

    def evaluated(w):
        """``G(jw)``, its relative estimate (0 where G vanishes: no absolute error to speak of)
        and ``max |G|`` per point."""
        count[0] += w.size
        G, rounding, inherent = modal.evaluate(1j * w)
        scale = np.abs(G).reshape(w.size, -1).max(axis=1)
        return G, np.where(scale > 0, rounding + inherent, 0.0), scale

    def at(w) -> tuple[NDArray, NDArray]:
        """sigma_max(G(jw)) and the evaluation's absolute estimate, at points only."""
        G, rel, scale = evaluated(np.atleast_1d(np.asarray(w, dtype=float)))
        return _sigma(G), rel * scale

    def bounds(c, h):
        """sigma_max(G(jc)), the bound over [c - h, c + h] and the evaluation estimate in it."""
        s = 1j * c
        G, rel, scale = evaluated(c)
        err = rel * scale
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            R = 1.0 / (s[:, None] - lam[None, :])
            Gp = -1j * ((R * R) @ K).reshape(c.size, p, m)
            gap = np.maximum(np.abs(lam.imag[None, :] - c[:, None]) - h[:, None], 0.0)
            dist = np.hypot(lam.real[None, :], gap)
            rem = (np.abs(R) ** 2 / dist) @ Knorm
            if k:
                M = s[:, None, None] * np.eye(k)[None] - T11[None]
                Minv = np.linalg.inv(M)
                X2 = Minv @ (Minv @ B1)
                Gp += -1j * (C1[None] @ X2)
                r = np.linalg.norm(Minv.reshape(c.size, -1), axis=1)
                q = h * r
                rem += np.where(q < 1, nC1 * r / (1 - q) * np.linalg.norm(X2.reshape(c.size, -1), axis=1), np.inf)
            top = np.maximum(_sigma(G + h[:, None, None] * Gp), _sigma(G - h[:, None, None] * Gp))
            nGp = np.linalg.norm(Gp.reshape(c.size, -1), axis=1)
            e = err + rel * h * nGp
            u = top + h * h * rem + e
        u = np.where(np.isnan(u), np.inf, u)
        return _sigma(G), u, e

    # the pole-aware grid: its largest value starts the branch and bound
    every = np.concatenate([lam, scipy.linalg.eigvals(T11)]) if k else lam
    w = pole_grid(every)
    g0, _ = at(w)
    j = int(np.argmax(g0))
    best_w, best = float(w[j]), float(g0[j])
    sD = float(np.linalg.norm(D, 2))
    if sD > best:
        best_w, best = math.inf, sD

    # the tail above W: sigma_max(G) <= sigma_max(D) + sum_i |K_i| / (W - |lambda_i|) (+ the block's)
    amax = max(float(np.max(np.abs(lam), initial=0.0)), nT11 if k else 0.0)

    def tail(W: float) -> float:
        t = float(np.sum(Knorm / (W - np.abs(lam))))
        if k:
            t += nC1 * nB1 / (W - nT11)
        return t

    W = max(2.0 * amax, float(w[-1]), np.finfo(float).tiny)
    for _ in range(200):
        if tail(W) <= 0.5 * rtol * max(best, np.finfo(float).tiny) or tail(W) == 0.0:
            break
        W *= 4.0
    tail_bound = sD + tail(W)
    edges = np.unique(np.concatenate([w[w < W], [W]]))
    a, b = edges[:-1], edges[1:]
    c, h = 0.5 * (a + b), 0.5 * (b - a)
    g, u, err = bounds(c, h)
    stuck = np.zeros(c.size, dtype=bool)
    certified = False
    why = ""
    while True:
        i = int(np.argmax(g))
        if g[i] > best:
            best, best_w = float(g[i]), float(c[i])
        thr = best * (1 + rtol)
        # halving shrinks the bound's own terms, not the evaluation's estimate: an interval is
        # halved while the rest exceeds thr, unless it is too short to halve
        stuck |= h <= 4 * EPS * np.maximum(c, np.finfo(float).tiny)
        active = np.flatnonzero((u - err > thr) & ~stuck)
        if active.size == 0:
            certified = not np.any((u - err > thr) & stuck) and tail_bound <= thr
            break
        if count[0] >= budget:
            why = f" (budget of {budget} evaluations spent)"
            break
        pick = active[np.argsort(u[active])[::-1][:_BATCH]]
        keep = np.ones(c.size, dtype=bool)
        keep[pick] = False
        ha = 0.5 * h[pick]
        cn = np.concatenate([c[pick] - ha, c[pick] + ha])
        hn = np.concatenate([ha, ha])
        gn, un, en = bounds(cn, hn)
        c, h = np.concatenate([c[keep], cn]), np.concatenate([h[keep], hn])
        g, u, err = np.concatenate([g[keep], gn]), np.concatenate([u[keep], un]), np.concatenate([err[keep], en])
        stuck = np.concatenate([stuck[keep], np.zeros(cn.size, dtype=bool)])
    if math.isfinite(best_w):
        # the value polished within its interval (the bound needs it only to rtol; a user reads it)
        hb = 2.0 * float(h[int(np.argmin(np.abs(c - best_w)))])
        res = scipy.optimize.minimize_scalar(lambda x: -float(at(x)[0][0]), bounds=(max(best_w - hb, 0.0), best_w + hb),
                                             method="bounded", options={"xatol": 1e-9 * max(hb, best_w)})
        if -res.fun > best:
            best, best_w = float(-res.fun), float(res.x)
    upper = max(float(np.max(u)), tail_bound, best)
    peak_err = 0.0 if math.isinf(best_w) else float(at(best_w)[1][0])
    if certified and not (peak_err <= rtol * best and upper <= best * (1 + 2 * rtol)):
        certified = False
        why = f" (the evaluations are known to {max(peak_err, float(np.max(err))) / best:.1g} relative only)"

    name = "block-modal" if isinstance(modal, _BlockModal) else "modal"
    return HinfNorm(best, best_w, certified, rtol, count[0],
                    f"interval bounds on the {name} form ({c.size} intervals){why}",
                    time.perf_counter() - t0, peak_err, upper)


def hinf_norm_stable(
    A: NDArray, B: NDArray, C: NDArray, D: NDArray, *, schur: tuple[NDArray, NDArray] | None = None,
    rtol: float = 1e-6, certify_max_states: int = CERTIFY_MAX_STATES,
) -> HinfNorm:
    """H-infinity norm of a stable system ``(A, B, C, D)``.

    Parameters
    ----------
    A, B, C, D : ndarray
        A stable real system.
    schur : (T, U), optional
        A complex Schur form ``A = U T U^H`` (``T`` upper triangular) when already available.
    rtol : float
        Relative accuracy of the refinement and of the certificate.
    certify_max_states : int
        Largest ``n`` for which the Hamiltonian certificate is computed.

    Notes
    -----
    1. The response ``C U (jw I - T)^-1 U^H B + D`` is evaluated by one triangular solve per
       frequency on a grid with 40 points per decade plus, for every pole ``a + jb``, the points
       ``|b|`` and ``|b| +- |a|`` (so a peak of damping ratio 1e-4 is never missed).
    2. The eight largest local maxima are refined by bounded scalar maximisation in log-frequency.
    3. Certificate (Bruinsma and Steinbuch, Systems & Control Letters 14, 1990; Boyd and
       Balakrishnan, 1990): the Hamiltonian matrix of ``gamma = value (1 + 2 rtol)`` has an
       imaginary eigenvalue ``jw`` iff a singular value equals ``gamma`` at ``w``. If it has some,
       the midpoints of the intervals they bound are evaluated, the lower bound raised, and the
       test repeated (at most 10 rounds). Imaginary-axis eigenvalues are detected with the
       tolerance ``1e-8 ||H||_1 + 1e-6 |lambda|``; when none of the frequencies they indicate
       raises the gain by more than ``rtol``, they are taken as round-off (spurious) and the value
       is reported as certified. The reported ``value`` is always attained (a true lower bound).
    """
    t0 = time.perf_counter()
    n, m = B.shape
    p = C.shape[0]
    if p == 0 or m == 0:
        return HinfNorm(0.0, 0.0, True, rtol, 0, "empty", time.perf_counter() - t0, 0.0, 0.0)
    if n == 0:
        val = float(np.linalg.norm(D, 2))
        return HinfNorm(val, 0.0, True, rtol, 1, "static gain", time.perf_counter() - t0, 0.0, val)
    if schur is None:
        T, U, _ = complex_schur(np.asarray(A, dtype=float))
    else:
        T, U = schur
    T = np.asfortranarray(np.array(T, dtype=complex))
    diag = np.diag(T).copy()
    CU = C @ U
    UB = U.conj().T @ B
    count = [0]

    def gain(w: float) -> float:
        count[0] += 1
        T[np.diag_indices(n)] = diag - 1j * w
        X = scipy.linalg.solve_triangular(T, UB, check_finite=False)  # (T - jw)^-1 = -(jw - T)^-1
        return float(np.linalg.svd(D - CU @ X, compute_uv=False)[0])

    w = pole_grid(diag)
    g = np.array([gain(x) for x in w])
    k = int(np.argmax(g))
    best_w, best = float(w[k]), float(g[k])

    def refine(candidates):
        nonlocal best_w, best
        best_w, best = refined(gain, w, candidates, rtol, best_w, best)

    refine(top_maxima(g))
    sD = float(np.linalg.norm(D, 2))
    if sD > best:   # the supremum is the high-frequency limit
        best_w, best = math.inf, sD

    certified = False
    method = "pole-aware sweep + local refinement"
    if n <= certify_max_states:
        method += " + Hamiltonian certificate"

        def gains(x):
            return np.array([gain(float(v)) for v in x])

        def refine_after(trial, best_w, best):
            nonlocal w
            w = np.unique(np.concatenate([w, trial]))
            j = int(np.searchsorted(w, best_w))
            return refined(gain, w, [min(max(j, 1), len(w) - 2)], rtol, best_w, best)

        best_w, best, certified = hamiltonian_peak(A, B, C, D, gains, best_w, best, rtol, refine=refine_after)
    # a-posteriori bound of the evaluation at the peak, from the one evaluator of linflex.frequency
    eval_err = 0.0   # at w -> inf the value is sigma_max(D), exact
    if best > 0 and math.isfinite(best_w):
        ev = TransferEvaluator(LinearSystem(A, B, C, D))
        ev(np.array([max(best_w, 1e-300)]))
        eval_err = float(ev.last_error[0]) * best
    if not eval_err <= rtol * best:
        certified = False
        method += f" (not certified: evaluation error bound {eval_err:.2g} above rtol * value)"
    return HinfNorm(
        value=best, omega=best_w, certified=certified, rtol=rtol, n_evaluations=count[0], method=method,
        seconds=time.perf_counter() - t0, evaluation_error=eval_err,
        upper=best * (1 + 2 * rtol) if certified else math.inf,
    )


def pole_grid(poles: NDArray[np.complex128]) -> NDArray[np.float64]:
    """Frequencies [rad/s] for a peak search: 40 per decade from a hundredth of the slowest
    non-zero pole to a hundred times the fastest, plus ``|b|`` and ``|b| +- |a|`` of every pole
    ``a + jb`` (a peak of damping ratio 1e-4 is not missed) and 0."""
    mags = np.abs(poles)
    lo = max(np.min(mags[mags > 0]) / 100 if np.any(mags > 0) else 1e-3, 1e-12)
    hi = max(np.max(mags, initial=0.0) * 100, 10 * lo)
    grid = [np.geomspace(lo, hi, int(np.ceil(40 * np.log10(hi / lo))) + 2)]
    b, a = np.abs(poles.imag), np.abs(poles.real)
    up = poles.imag >= 0
    grid += [b[up], (b + a)[up], np.clip(b - a, 0, None)[up]]
    return np.unique(np.concatenate(grid + [np.zeros(1)]))


def top_maxima(g: NDArray[np.float64], count: int = 8) -> NDArray[np.intp]:
    """Indices of the ``count`` largest interior local maxima of ``g``, largest first (equal ones
    in the order of ``g``)."""
    interior = np.flatnonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1
    return interior[np.argsort(-g[interior], kind="stable")[:count]]


def refined(gain, w, candidates, rtol: float, best_w: float, best: float) -> tuple[float, float]:
    """``(omega, value)`` of the largest ``gain`` after a bounded scalar maximisation in
    log-frequency between the neighbours of each candidate grid index (``best_w``, ``best``: the
    largest so far)."""
    for i in candidates:
        left = w[max(i - 1, 0)]
        right = w[min(i + 1, len(w) - 1)]
        if right <= left:
            continue
        if left <= 0:
            left = right * 1e-6
        res = scipy.optimize.minimize_scalar(
            lambda s: -gain(float(np.exp(s))), bounds=(np.log(left), np.log(right)), method="bounded",
            options={"xatol": rtol * 1e-2},
        )
        if -res.fun > best:
            best, best_w = float(-res.fun), float(np.exp(res.x))
    return best_w, best


def hamiltonian_peak(A, B, C, D, gains, best_w: float, best: float, rtol: float, *, rounds: int = 10,
                     refine=None) -> tuple[float, float, bool]:
    """Raise a lower bound ``best`` (attained at ``best_w`` [rad/s]) of ``sup_w sigma_max(G(jw))``
    to within ``rtol`` of the supremum by the Hamiltonian test (Bruinsma and Steinbuch, Systems &
    Control Letters 14, 1990; Boyd and Balakrishnan, 1990).

    Each round takes the imaginary eigenvalues ``jw`` of the Hamiltonian matrix of ``gamma = best
    (1 + 2 rtol)`` (a singular value of ``G(jw)`` equals ``gamma`` there, :func:`_imaginary_hamiltonian_eigs`):
    none, and ``best`` is within ``2 rtol`` of the supremum (certified). Otherwise ``gains`` (the
    largest singular value at an array of frequencies [rad/s], one call per round) is evaluated at
    those frequencies, at 0 and at the midpoints between them (the intervals where it exceeds
    ``gamma`` lie between consecutive crossings): the midpoints raise ``best`` quadratically fast.
    When no point raises it by more than ``rtol`` the eigenvalues were round-off (a spurious
    crossing at the tolerance's level) and the value is taken as certified. ``refine(trial,
    best_w, best) -> (best_w, best)``: an optional local search after a round that raised
    ``best``. ``A`` must have no eigenvalue on the imaginary axis.

    Returns ``(best_w, best, certified)``; ``best`` is always a value ``gains`` returned (attained);
    not certified when ``gains`` returns a value that is not finite.
    """
    certified = False
    for _ in range(rounds):
        gamma = best * (1 + 2 * rtol)
        if gamma == 0:
            return best_w, best, True
        freqs = _imaginary_hamiltonian_eigs(A, B, C, D, gamma)
        if freqs.size == 0:
            return best_w, best, True
        freqs = np.unique(np.concatenate([freqs, [0.0]]))
        trial = np.concatenate([freqs, 0.5 * (freqs[1:] + freqs[:-1])])
        vals = np.asarray(gains(trial), dtype=float)
        if not np.all(np.isfinite(vals)):   # an evaluation failed: no certificate from this round
            return best_w, best, False
        before = best
        j = int(np.argmax(vals))
        if vals[j] > best:
            best, best_w = float(vals[j]), float(trial[j])
        if best <= before * (1 + rtol):
            # the imaginary eigenvalues did not lead to a larger gain: they are spurious
            # (numerical) crossings at the level of the tolerance, accept the value
            return best_w, best, True
        if refine is not None:
            best_w, best = refine(trial, best_w, best)
    return best_w, best, certified


def _imaginary_hamiltonian_eigs(A, B, C, D, gamma) -> NDArray[np.float64]:
    """Frequencies w >= 0 where some singular value of the response equals gamma."""
    m, p = B.shape[1], C.shape[0]
    R = D.T @ D - gamma**2 * np.eye(m)
    S = D @ D.T - gamma**2 * np.eye(p)
    Ri = np.linalg.solve(R, np.eye(m))
    Si = np.linalg.solve(S, np.eye(p))
    H = np.block([
        [A - B @ Ri @ D.T @ C, -gamma * B @ Ri @ B.T],
        [gamma * C.T @ Si @ C, -A.T + C.T @ D @ Ri @ B.T],
    ])
    ev = scipy.linalg.eigvals(H, check_finite=False)
    scale = np.linalg.norm(H, 1)
    imag = ev[np.abs(ev.real) <= 1e-8 * scale + 1e-6 * np.abs(ev)]
    return np.unique(np.abs(imag.imag))



def _sigma(G: NDArray) -> NDArray[np.float64]:
    """Largest singular value of each matrix of a stack ``(N, p, m)``."""
    if G.shape[1] == 1 or G.shape[2] == 1:
        return np.linalg.norm(G.reshape(G.shape[0], -1), axis=1)
    return np.linalg.svd(G, compute_uv=False)[:, 0]

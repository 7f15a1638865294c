"""Disk margins: the gain and phase variations a loop tolerates simultaneously.

``alpha = 1 / max_w mu(S(jw) + (sigma - 1)/2 I)`` (Seiler, Packard and Gahinet, "An introduction
to disk margins", IEEE Control Systems Magazine 40(5), 2020), ``mu`` being ``|.|`` for a single
loop, the D-scaled upper bound of the structured singular value for independent perturbations
of every channel, or ``sigma_max`` for a full perturbation matrix.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray
from scipy.optimize.elementwise import find_minimum

from linflex.frequency._evaluate import WARN_RTOL, TransferEvaluator
from linflex.frequency._hinf import hamiltonian_peak, top_maxima
from linflex.frequency._modal_forms import balance_system

__all__ = ["DiskMargin", "disk_margin"]

#: Points sampled on each side of a peak's grid bracket before its local search.
SUBSAMPLES = 8

#: A peak's search also stops when its bracket is flat to rounding, ``(f_l - 2 f_m + f_r)/2 <=
#: FLAT |f_m|``: the peak value is then known to round-off, and the peak frequency cannot be
#: located better than about ``sqrt(FLAT)`` relative (the value's rounding noise decides).
FLAT = 8 * np.finfo(float).eps

#: Largest number of states of the sensitivity's realization for which :func:`disk_margin` finds
#: the peak by the Hamiltonian iteration (:func:`~linflex.frequency._hinf.hamiltonian_peak`, an
#: eigenvalue problem of twice that order per round) rather than by the grid search.
HAMILTONIAN_MAX = 100
#: Relative accuracy [-] of the Hamiltonian iteration's peak value (the grid search's is rounding).
HAMILTONIAN_RTOL = 1e-13


@dataclass(frozen=True)
class DiskMargin:
    """A disk margin and the gain and phase variations it guarantees.

    Attributes
    ----------
    alpha : float
        Size [-] of the largest disk of multiplicative perturbations the loop tolerates:
        ``alpha = 1 / max_w mu(S(jw) + (skew - 1)/2 I)``, ``mu`` being ``|.|`` for a single
        loop and as stated by ``structure`` for several (0 when the nominal closed loop is
        unstable).
    skew : float
        Skew ``sigma`` [-] of the disk: 0 balanced (``S - T``)/2, 1 sensitivity ``S``, -1
        complementary sensitivity ``T``.
    frequency : float
        Frequency [rad/s] of the peak that sets ``alpha`` (``nan`` when the closed loop is
        unstable).
    gain_margin : tuple of float
        ``(low, high)``: simultaneous gain changes in this range [ratio] keep the loop stable
        (``high`` is ``inf`` when the disk contains all of ``[1, inf)``).
    phase_margin : float
        Phase change [deg] tolerated (simultaneously in all loops for a multi-loop margin).
    structure : str
        ``"siso"`` (exact for the single loop); ``"diagonal"``: multi-loop margin for
        independent, simultaneous complex perturbations of every channel, ``alpha = 1 / max_w
        mu_ub`` with the D-scaled upper bound ``mu_ub = min_D sigma_max(D M D^-1)`` of the
        structured singular value, hence a (slightly conservative) lower bound of the exact
        multi-loop margin; ``"unstructured"``: ``alpha`` from the largest singular value of
        ``S + (skew-1)/2 I`` (a full perturbation matrix), a lower bound of both.
    """

    alpha: float
    skew: float
    frequency: float
    gain_margin: tuple[float, float]
    phase_margin: float
    structure: str

    @property
    def gain_margin_db(self) -> tuple[float, float]:
        """``gain_margin`` [dB]."""
        with np.errstate(divide="ignore"):
            return tuple(float(20 * np.log10(g)) for g in self.gain_margin)


def _disk(alpha: float, skew: float, frequency: float, structure: str) -> DiskMargin:
    """Gain and phase ranges of the disk ``{(1 + (1-s)/2 d) / (1 - (1+s)/2 d) : |d| <= alpha}``.

    Seiler, Packard and Gahinet (2020), "An introduction to disk margins", IEEE Control Systems
    Magazine 40(5), eqs. for gamma_min, gamma_max and the phase margin.
    """
    a, s = alpha, skew
    if np.isinf(a):  # S + (s - 1)/2 vanishes (a static loop): the limit of every gain and phase
        return DiskMargin(alpha=float(a), skew=float(s), frequency=float(frequency), gain_margin=(0.0, np.inf),
                          phase_margin=180.0, structure=structure)
    # real end points of the boundary circle; x2 < 0 when the "disk" is the outside of a circle
    # (a (1 + s) > 2), which then holds every gain above x1
    x1 = (2 - a * (1 - s)) / (2 + a * (1 + s))
    den = 2 - a * (1 + s)
    x2 = (2 + a * (1 - s)) / den if den != 0 else np.inf
    low = max(x1, 0.0)
    high = x2 if den > 0 else np.inf
    # the boundary circle meets the unit circle where cos(phi) = (1 + x1 x2) / (x1 + x2)
    # (-> x1 as x2 -> inf)
    c = x1 if np.isinf(x2) else (1 + x1 * x2) / (x1 + x2)
    phase = 0.0 if a == 0 else float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    return DiskMargin(alpha=float(a), skew=float(s), frequency=float(frequency),
                      gain_margin=(float(low), float(high)), phase_margin=phase, structure=structure)


def not_computed(skew: float, structure: str) -> DiskMargin:
    """The disk margin of ``structure`` not searched (``stability_margins(...,
    disk_margins="multi-loop")``): every number ``nan``."""
    nan = float("nan")
    return DiskMargin(alpha=nan, skew=float(skew), frequency=nan, gain_margin=(nan, nan), phase_margin=nan,
                      structure=structure)


def _osborne_log_scaling(M: NDArray[np.complex128], sweeps: int = 25, tol: float = 1e-12) -> NDArray[np.float64]:
    """log of diagonal scalings D that balance the off-diagonal part of each ``M[k]`` (Osborne).

    Minimizing the Frobenius norm of ``D M D^-1`` row by row (Gauss-Seidel sweeps, vectorized over
    the first axis): row i and column i of ``|D M D^-1|^2`` are equalized by scaling ``d_i`` with
    ``(c_i / r_i)^(1/4)``. Any positive diagonal D gives an upper bound of mu; this one is a good
    start for the exact minimization of the largest singular value. The sweeps stop when no
    ``log d`` moved by more than ``tol`` in the last one (the iteration converges linearly; its
    fixed point is reached to ``tol`` long before ``sweeps`` on most matrices), or after
    ``sweeps``.
    """
    n, m, _ = M.shape
    P = np.abs(M) ** 2
    P[:, np.arange(m), np.arange(m)] = 0.0
    Pt = np.ascontiguousarray(P.transpose(0, 2, 1))  # Pt[:, i, :] is column i of P
    logd = np.zeros((n, m))
    tiny = np.finfo(float).tiny
    for _ in range(sweeps):
        before = logd
        logd = logd.copy()
        for i in range(m):
            x = 2.0 * (logd[:, i:i + 1] - logd)  # 2 (log d_i - log d_j)
            r = (P[:, i, :] * np.exp(x)).sum(axis=1)
            c = (Pt[:, i, :] * np.exp(-x)).sum(axis=1)
            ok = (r > tiny) & (c > tiny)
            logd[ok, i] += 0.25 * (np.log(c[ok]) - np.log(r[ok]))
        logd = np.clip(logd - logd[:, :1], -300, 300)
        if np.max(np.abs(logd - before), initial=0.0) <= tol:
            break
    return logd


def _peak_values(M: NDArray[np.complex128], structure: str) -> NDArray[np.float64]:
    """|M| (siso), sigma_max(M) (unstructured) or sigma_max(D M D^-1) with Osborne D (diagonal)."""
    if M.shape[1] == 1:
        return np.abs(M[:, 0, 0])
    if structure == "diagonal":
        logd = _osborne_log_scaling(M)
        M = M * np.exp(logd[:, :, None] - logd[:, None, :])
    return np.linalg.svd(M, compute_uv=False)[:, 0]


def _polished_mu(M: NDArray[np.complex128]) -> float:
    """min over positive diagonal D of sigma_max(D M D^-1) (the mu upper bound for scalar complex
    blocks), by Nelder-Mead in log D from the Osborne scaling; the problem is convex in log D."""
    m = M.shape[0]
    x0 = _osborne_log_scaling(M[None])[0, 1:]

    def f(x):
        logd = np.concatenate([[0.0], x])
        return float(np.linalg.svd(M * np.exp(logd[:, None] - logd[None, :]), compute_uv=False)[0])

    start = f(x0)
    if m == 1:
        return start
    res = scipy.optimize.minimize(f, x0, method="Nelder-Mead",
                                  options={"xatol": 1e-10, "fatol": 1e-14 * start, "maxiter": 4000})
    return min(start, float(res.fun))


#: Relative distance [-] to a hidden undamped mode within which :func:`disk_margin` does not use
#: the peak function (the grids keep 1e-6 off it: ``frequency/_spectrum.py: avoid_axis_poles``).
AVOID_RTOL = 1e-7
#: Relative distance [-] to a hidden undamped mode within which :func:`disk_margin` does not use
#: the peak function where its evaluation is estimated worse than ``WARN_RTOL`` (the residue's
#: rounding reaches further than ``AVOID_RTOL`` when the realization is badly conditioned: a PD
#: loop with ``zeta = 0.99999``, flat-peaked, and a hidden mode 3.8 % below the peak had its
#: peak searched to 1e-6 of the mode, where the estimate is 1.1e-3).
NEAR_RTOL = 1e-3


def disk_margin(evs, grid, skew: float, stable: bool, structure: str, max_points: int, avoid=()) -> DiskMargin:
    """alpha = 1 / max_w mu(S(jw) + (skew - 1)/2 I): the Hamiltonian iteration on small loops,
    else a grid search plus local refinement.

    A continuous, undelayed loop whose ``S`` has a dense realization of at most
    :data:`HAMILTONIAN_MAX` states and no hidden undamped mode, with ``mu`` a largest singular
    value (``"siso"``, ``"unstructured"``, a single channel), has its peak from the Hamiltonian
    iteration (:func:`_hamiltonian_candidates`; measured on the hub loops of
    ``benchmarks/margins.py``: 1.5 to 2 times faster than the grid search from 5 to 61 states,
    equal near 100 to 200); its values are the evaluator's, as the grid search's. Otherwise:

    ``mu`` is ``|.|`` for a single loop, ``sigma_max`` for ``structure="unstructured"`` and the
    D-scaled upper bound ``min_D sigma_max(D M D^-1)`` for ``structure="diagonal"``
    (independent complex perturbations of each channel). ``evs`` holds one evaluator of ``S``
    (for MIMO, the full sensitivity matrix). The grid is the pole-aware grid of the loop (which
    has clusters at the lightly damped closed-loop poles), refined where the peak function
    changes by more than 0.1 dB, with ``w = 0`` and ``w = inf`` added. The brackets of the
    eight largest local maxima are sampled at ``SUBSAMPLES`` more points a side (two maxima of a
    multi-loop peak can share one), and the eight largest local maxima of that grid are searched
    together in ``log w`` within their brackets (:func:`scipy.optimize.elementwise.find_minimum`,
    one evaluation of the loop per step for all of them) to 1e-10 or until the bracket is flat
    to rounding (``FLAT``). For the diagonal structure the best candidates are then polished by
    an exact minimization over D (those that cannot win are skipped: polishing only lowers a
    candidate). ``avoid``: frequencies [rad/s] of hidden undamped modes
    (:func:`~linflex.frequency._nyquist.loop_poles`), in ``S``'s realization with a residue known to rounding
    only: within ``AVOID_RTOL`` of them, and within ``NEAR_RTOL`` where the evaluation's estimate
    is above ``WARN_RTOL``, the peak function is not used (its rounding over the distance would
    make a spurious peak there, which the search would climb).
    """
    if not stable:
        return _disk(0.0, skew, np.nan, structure)
    ev = evs[0]
    c = (skew - 1.0) / 2.0
    eye = np.eye(ev.D.shape[1])

    avoid = np.asarray(avoid, dtype=float)

    def peak(w):
        M = ev(w) + c * eye[None]
        finite = np.all(np.isfinite(M), axis=(1, 2))   # else a pole of S on the axis: an infinite peak
        vals = np.full(w.size, np.inf)
        vals[finite] = _peak_values(M[finite], structure)
        if avoid.size:
            with np.errstate(divide="ignore", invalid="ignore"):
                distance = np.min(np.abs(w[:, None] - avoid[None, :]) / avoid[None, :], axis=1)
            # a hidden pole at the origin (a rigid axis outside the loop): only w = 0 itself (0 / 0)
            distance = np.where(np.isnan(distance), 0.0, distance)
            inaccurate = ~(np.asarray(ev.last_error, dtype=float) <= WARN_RTOL)
            vals = np.where((distance <= AVOID_RTOL) | ((distance <= NEAR_RTOL) & inaccurate), 0.0, vals)
        return vals

    realization = _sensitivity_realization(ev, c, structure, avoid)
    cands = _hamiltonian_candidates(realization, peak) if realization is not None else None
    if cands is None:
        cands = _grid_candidates(peak, ev, grid, c * eye, structure, max_points)
    if structure == "diagonal" and eye.shape[0] > 1:
        # polishing only lowers a candidate (mu_ub <= its Osborne value): one whose Osborne value
        # is below the best polished value (less the tie tolerance below) can neither win nor tie
        polished = []
        for v, wc in sorted(cands, key=lambda t: -t[0])[:4]:
            if polished and v < max(p for p, _ in polished) * (1 - 1e-9):
                break
            Mc = (ev.D + c * eye).astype(complex) if np.isinf(wc) else ev(np.array([wc]))[0] + c * eye
            polished.append((_polished_mu(Mc), wc))
        cands = polished
    # on a plateau (S -> 1 both at w -> 0 and w -> inf, say) report the first of the tied
    # candidates in the order w = 0, w = inf, interior peaks, rather than a rounding-noise winner
    top = max(v for v, _ in cands)
    best, best_w = next((v, wc) for v, wc in cands if v >= top * (1 - 1e-9))
    best = top
    alpha = 1.0 / best if best > 0 else np.inf
    return _disk(alpha, skew, best_w, structure)


def _grid_candidates(peak, ev, grid, shift, structure: str, max_points: int) -> list[tuple[float, float]]:
    """``(value, frequency)`` candidates of the peak of ``peak`` (the peak function of ``S +
    shift``): ``w = 0``, ``w = inf``, the refined largest maxima of the grid and its largest
    point (:func:`disk_margin`'s grid search)."""
    w = grid
    vals = peak(w)
    for _ in range(8):
        with np.errstate(divide="ignore", invalid="ignore"):
            dl = np.abs(np.log10(vals[1:] / vals[:-1]))
        bad = (dl > 0.005) & (w[1:] / w[:-1] > 1 + 1e-12)
        if not bad.any() or w.size + bad.sum() > max_points:
            break
        i = np.flatnonzero(bad)
        mid = np.sqrt(w[i] * w[i + 1])
        w = np.insert(w, i + 1, mid)
        vals = np.insert(vals, i + 1, peak(mid))
    cands = [(float(peak(np.array([0.0]))[0]), 0.0),
             (float(_peak_values((ev.D + shift)[None].astype(complex), structure)[0]), np.inf)]
    top = top_maxima(vals)
    if top.size:
        # sample the brackets of the largest maxima, then search the largest maxima of that grid
        t = np.log(w)
        frac = np.linspace(0.0, 1.0, SUBSAMPLES + 2)[1:-1]
        extra = np.concatenate([(t[top - 1, None] + (t[top] - t[top - 1])[:, None] * frac).ravel(),
                                (t[top, None] + (t[top + 1] - t[top])[:, None] * frac).ravel()])
        t, first = np.unique(np.concatenate([t, extra]), return_index=True)
        vals = np.concatenate([vals, peak(np.exp(extra))])[first]
        w = np.exp(t)
        top = top_maxima(vals)
        with np.errstate(invalid="ignore", divide="ignore"):  # a flat bracket's quadratic fit
            res = find_minimum(lambda x: -peak(np.exp(x)), (t[top - 1], t[top], t[top + 1]),
                               tolerances={"xatol": 1e-10, "xrtol": 0.0, "frtol": FLAT})
        for i, x, fx in zip(top, np.atleast_1d(res.x), np.atleast_1d(res.f_x)):
            refined = (-float(fx), float(np.exp(x))) if np.isfinite(fx) else (-np.inf, np.nan)
            cands.append(max(refined, (float(vals[i]), float(w[i]))))
    if vals.size:
        j = int(np.argmax(vals))
        cands.append((float(vals[j]), float(w[j])))
    return cands


def _sensitivity_realization(ev, c: float, structure: str, avoid) -> tuple | None:
    """A balanced realization ``(A, B, C, D)`` of ``S + c I`` when the Hamiltonian iteration
    applies: an evaluator of a continuous, undelayed, dense ``S`` (a multivariable closed loop's
    own, or a single loop's ``realization()``, :func:`~._closed_loop.sensitivity_system`) of at most
    :data:`HAMILTONIAN_MAX` states, with no hidden undamped mode (``avoid`` empty) and a peak
    function that is a largest singular value (not the D-scaled bound of several channels). None
    otherwise (a delayed loop's ``S`` is not rational in ``s``, and has no realization)."""
    if len(avoid) or (structure == "diagonal" and ev.D.shape[0] > 1):
        return None
    if isinstance(ev, TransferEvaluator):
        sys = ev.sys
    else:
        sys = ev.realization(HAMILTONIAN_MAX) if hasattr(ev, "realization") else None
    if sys is None or sys.is_sparse or not 0 < sys.n_states <= HAMILTONIAN_MAX:
        return None
    A, B, C, D = (np.asarray(x, dtype=float) for x in (sys.A, sys.B, sys.C, sys.D))
    if not np.all(np.isfinite(A)):
        return None
    A, B, C = balance_system(A, B, C)
    return A, B, C, D + c * np.eye(D.shape[0])


def _hamiltonian_candidates(realization, peak) -> list[tuple[float, float]] | None:
    """``(value, frequency)`` candidates of the peak of ``sigma_max(S + c I)`` for a stable
    ``realization`` of it: ``w = 0``, ``w = inf`` and the peak found by the Hamiltonian iteration
    (:func:`~linflex.frequency._hinf.hamiltonian_peak`, to :data:`HAMILTONIAN_RTOL`) from the best
    of the closed-loop poles' magnitudes and imaginary parts (Bruinsma and Steinbuch's start),
    every value from ``peak`` (the evaluator's). None when the iteration does not certify its
    value (the grid search is then used)."""
    A, B, C, D = realization
    poles = np.linalg.eigvals(A)
    start = np.unique(np.concatenate([[0.0], np.abs(poles), np.abs(poles.imag)]))
    start = start[np.isfinite(start)]
    vals = peak(start)   # start[0] is w = 0
    cands = [(float(vals[0]), 0.0), (float(np.linalg.norm(D, 2)), np.inf)]
    best, best_w = max(cands)
    j = int(np.argmax(vals))
    if vals[j] > best:
        best, best_w = float(vals[j]), float(start[j])
    best_w, best, certified = hamiltonian_peak(A, B, C, D, peak, best_w, best, HAMILTONIAN_RTOL, rounds=30)
    if not certified:
        return None
    cands.append((best, best_w))
    return cands

"""Measured H-infinity norm of a stable error system: dense pole-aware sweep, refinement, certificate.

Used by the reductions when the caller asks for a measured error (``measure_error=True``).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import NDArray

from linflex import AccuracyWarning, LinearSystem
from linflex.frequency._evaluate import TransferEvaluator
from linflex.system import complex_schur

__all__ = ["ErrorMeasurement", "hinf_norm_stable", "stable_parts_error", "checked_against_full",
           "sparse_error_sweep"]

#: Largest state count for which the Hamiltonian certificate (an eigenvalue problem of twice that
#: size) is computed; above it the measured value is a lower bound from the refined sweep.
CERTIFY_MAX_STATES = 500


@dataclass(frozen=True)
class ErrorMeasurement:
    """A measured H-infinity norm ``max_w sigma_max(E(jw))`` of an error system ``E``.

    Attributes
    ----------
    value : float
        The largest singular value found [output units per input unit]; always attained at
        ``omega`` (a true lower bound).
    omega : float
        Frequency [rad/s] where ``value`` is attained.
    certified : bool
        True when the Hamiltonian test at ``value * (1 + rtol)`` found no imaginary-axis
        eigenvalue, i.e. the true norm is below ``value * (1 + rtol)``.
    rtol : float
        Relative accuracy of the certificate.
    n_evaluations : int
        Number of frequency points evaluated (``evaluations``, the former name, is kept as a
        read-only alias).
    method : str
        How it was obtained.
    seconds : float
        Wall time [s].
    evaluation_error : float
        A-posteriori bound [output units per input unit] of the error of the evaluations behind
        ``value`` (the one evaluator of :mod:`linflex.frequency`, ``frequency/_evaluate.py``): at
        the peak for ``hinf_norm_stable``; the largest over the frequencies of the second
        path for ``checked_against_full``. ``certified`` requires it below ``rtol * value``
        at the peak (see ``checked_against_full`` for the rest of the axis).
    """

    value: float
    omega: float
    certified: bool
    rtol: float
    n_evaluations: int
    method: str
    seconds: float
    evaluation_error: float = 0.0


def hinf_norm_stable(
    A: NDArray, B: NDArray, C: NDArray, D: NDArray, *, schur: tuple[NDArray, NDArray] | None = None,
    rtol: float = 1e-6, certify_max_states: int = CERTIFY_MAX_STATES,
) -> ErrorMeasurement:
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
        return ErrorMeasurement(0.0, 0.0, True, rtol, 0, "empty", time.perf_counter() - t0)
    if n == 0:
        val = float(np.linalg.norm(D, 2))
        return ErrorMeasurement(val, 0.0, True, rtol, 1, "static gain", time.perf_counter() - t0)
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

    w = _pole_grid(diag)
    g = np.array([gain(x) for x in w])
    k = int(np.argmax(g))
    best_w, best = float(w[k]), float(g[k])

    def refine(candidates):
        nonlocal best_w, best
        best_w, best = _refined(gain, w, candidates, rtol, best_w, best)

    refine(_top_maxima(g))

    certified = False
    method = "pole-aware sweep + local refinement"
    if n <= certify_max_states:
        method += " + Hamiltonian certificate"
        for _ in range(10):
            gamma = best * (1 + 2 * rtol)
            if gamma == 0:
                certified = True
                break
            freqs = _imaginary_hamiltonian_eigs(A, B, C, D, gamma)
            if freqs.size == 0:
                certified = True
                break
            freqs = np.unique(np.concatenate([freqs, [0.0]]))
            trial = np.concatenate([freqs, 0.5 * (freqs[1:] + freqs[:-1])])
            before = best
            for x in trial:
                val = gain(float(x))
                if val > best:
                    best, best_w = val, float(x)
            w = np.unique(np.concatenate([w, trial]))
            if best <= before * (1 + rtol):
                # the imaginary eigenvalues did not lead to a larger gain: they are spurious
                # (numerical) crossings at the level of the tolerance, accept the value
                certified = True
                break
            j = int(np.searchsorted(w, best_w))
            refine([min(max(j, 1), len(w) - 2)])
    # a-posteriori bound of the evaluation at the peak, from the one evaluator of linflex.frequency
    ev = TransferEvaluator(LinearSystem(A, B, C, D))
    ev(np.array([max(best_w, 1e-300)]))
    eval_err = float(ev.last_error[0]) * best if best > 0 else 0.0
    if not eval_err <= rtol * best:
        certified = False
        method += f" (not certified: evaluation error bound {eval_err:.2g} above rtol * value)"
    return ErrorMeasurement(
        value=best, omega=best_w, certified=certified, rtol=rtol, n_evaluations=count[0], method=method,
        seconds=time.perf_counter() - t0, evaluation_error=eval_err,
    )


def _pole_grid(poles: NDArray[np.complex128]) -> NDArray[np.float64]:
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


def _top_maxima(g: NDArray[np.float64], count: int = 8) -> NDArray[np.intp]:
    """Indices of the ``count`` largest interior local maxima of ``g``."""
    interior = np.nonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:]))[0] + 1
    return interior[np.argsort(g[interior])[::-1][:count]]


def _refined(gain, w, candidates, rtol: float, best_w: float, best: float) -> tuple[float, float]:
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


def sparse_error_sweep(full: LinearSystem, reduced: LinearSystem, *, rtol: float = 1e-6) -> ErrorMeasurement:
    """A measured ``||G - G_r||_inf`` of a reduction of a sparse system (``full.A`` sparse).

    ``G`` by the engine's sparse path (one sparse LU per frequency), ``G_r`` by its own dense one,
    on the grid of :func:`_pole_grid` over the *reduced* system's poles (the sparse system's are
    not all known), the eight largest local maxima refined. The value is attained (a lower bound
    of the norm) and never certified: a peak of the error between grid points, far from every
    reduced pole, can be missed. ``evaluation_error`` is the two evaluations' bound at the peak.
    """
    t0 = time.perf_counter()
    evf, evr = TransferEvaluator(full), TransferEvaluator(reduced)
    count = [0]

    def gain(w: float) -> float:
        count[0] += 1
        return float(np.linalg.svd(evf([w])[0] - evr([w])[0], compute_uv=False)[0])

    w = _pole_grid(evr.poles if reduced.n_states else np.zeros(0, complex))
    Gf, Gr = evf(w), evr(w)
    count[0] += w.size
    g = np.linalg.svd(Gf - Gr, compute_uv=False)[:, 0]
    k = int(np.argmax(g))
    best_w, best = _refined(gain, w, _top_maxima(g), rtol, float(w[k]), float(g[k]))
    Gf_peak = evf([best_w])
    Gr_peak = evr([best_w])
    eval_err = float(evf.last_error[0] * np.abs(Gf_peak).max() + evr.last_error[0] * np.abs(Gr_peak).max())
    return ErrorMeasurement(
        value=best, omega=best_w, certified=False, rtol=rtol, n_evaluations=count[0],
        method="sweep over the reduced poles + local refinement (sparse system: a lower bound, not certified)",
        seconds=time.perf_counter() - t0, evaluation_error=eval_err,
    )


def checked_against_full(full, reduced, measured: ErrorMeasurement, *, n_points: int = 60) -> ErrorMeasurement:
    """A second, independent path for a measured reduction error ``||G - G_r||``.

    ``G`` and ``G_r`` are evaluated separately by the one evaluator of :mod:`linflex.frequency`
    (each with its a-posteriori error bound) at the measured peak and on ``n_points``
    logarithmically spaced frequencies from a decade below the slowest to a decade above the
    fastest non-zero pole of ``G`` (never on an undamped pole). The measurement of the stable parts alone misses errors of the split into
    unstable and stable parts (a slow pole at -1e-8 beside one at -1e6 is only known to 2e-10,
    2 % of itself): where ``sigma_max(G - G_r)`` minus the evaluation bounds exceeds the
    measured value, that difference becomes the value (still attained, to within the bounds) and
    the result is not certified; it is not certified either when the evaluation bounds exceed
    ``rtol * value`` at the peak or the value anywhere above a tenth of the slowest non-rigid
    pole (rigid-body poles are kept, not approximated, by the reductions). ``evaluation_error``
    is the largest bound over all the frequencies checked, rigid-body range included.

    Parameters
    ----------
    full, reduced : LinearSystem
        The system and its reduction.
    measured : ErrorMeasurement
        The measurement of the stable parts.
    n_points : int
        Frequencies of the check.

    Returns
    -------
    ErrorMeasurement
        ``measured`` with the check added to ``method`` and ``evaluation_error``, corrected where
        the check contradicts it.

    Warns
    -----
    AccuracyWarning
        When the evaluations of ``G`` and ``G_r`` are less accurate than the measured value,
        with the frequency and the cause.
    """
    import dataclasses

    from linflex.frequency._spectrum import avoid_axis_poles, classify

    evf, evr = TransferEvaluator(full), TransferEvaluator(reduced)
    spec = classify(full.A, poles=evf.poles, B=full.B, C=full.C)
    # every pole sets the range here, slow ones included: that is where a split loses accuracy
    mags = np.abs(spec.poles)
    mags = mags[mags > 0]
    lo, hi = (mags.min() / 10, mags.max() * 10) if mags.size else (0.1, 10.0)
    w = avoid_axis_poles(np.geomspace(lo, hi, n_points), spec)
    nonrigid = np.abs(spec.poles[~spec.rigid])
    cutoff = nonrigid[nonrigid > 0].min() / 10 if np.any(nonrigid > 0) else 0.0
    # a peak inside the rigid-body range (a static peak, refined to some omega ~ 1e-17) is checked
    # like a peak at omega = 0: there G and G_r are dominated by the rigid part they share exactly,
    # and evaluating them says nothing about G - G_r
    at_peak = measured.omega > 0 and not (np.any(spec.rigid) and measured.omega < cutoff)
    if at_peak:
        w = np.concatenate([[measured.omega], w])
    w = w[np.isfinite(w) & (w > 0)]
    if np.all(spec.poles != 0):
        # the static gains too: below the slowest pole G - G_r may keep growing towards omega = 0
        w = np.concatenate([w, [0.0]])
    Gf, Gr = evf(w), evr(w)
    ef, er = evf.last_error, evr.last_error
    diff = np.linalg.svd(Gf - Gr, compute_uv=False)[:, 0]
    with np.errstate(invalid="ignore"):
        bound = ef * np.abs(Gf).max(axis=(1, 2)) + er * np.abs(Gr).max(axis=(1, 2))
    bound = np.where(np.isfinite(bound), bound, np.inf)
    sure = diff - bound
    value, omega, certified = measured.value, measured.omega, measured.certified
    method = measured.method + " + direct check of G - G_r"
    why = ""
    j = int(np.argmax(sure))
    if sure[j] > measured.value * (1 + measured.rtol):
        value, omega, certified = float(diff[j]), float(w[j]), False
        why = f"G - G_r reaches {diff[j]:.3g} at omega = {w[j]:.6g} rad/s"
    tiny = np.finfo(float).tiny
    peak = 0 if at_peak else int(np.argmin(bound))
    # above the rigid-body poles (which reductions keep, not approximate) the two evaluations must
    # be accurate to the measured value, and to rtol of it at the peak
    flexible = w >= cutoff
    k = int(np.argmax(np.where(flexible, bound, -np.inf))) if np.any(flexible) else peak
    if not why and not bound[peak] <= measured.rtol * max(value, tiny):
        k, why = peak, f"G and G_r are only known to {bound[peak]:.3g} at the peak"
    elif not why and np.any(flexible) and not bound[k] <= max(value, tiny):
        why = f"G and G_r are only known to {bound[k]:.3g} at omega = {w[k]:.6g} rad/s"
    if why:
        method += f" ({why})"
        ev = evf if ef[k] * np.abs(Gf[k]).max() >= er[k] * np.abs(Gr[k]).max() else evr
        warnings.warn(
            f"reduction error: ||G - G_r|| = {value:.3g} is not certified: {why} "
            f"(cause: {ev.cause(1j * w[k])})", AccuracyWarning, stacklevel=3,
        )
        certified = False
    worst = float(np.max(bound))
    return dataclasses.replace(measured, value=value, omega=omega, certified=certified, method=method,
                               evaluation_error=max(measured.evaluation_error, worst))


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


def stable_parts_error(full, reduced) -> ErrorMeasurement:
    """H-infinity norm of the difference of the stable parts of two first-order systems.

    Both are split by :func:`split_stable` (default threshold); their rigid/unstable parts are
    not compared (they are kept, not approximated, by the reductions that use this).
    """
    from ._reduction_split import split_stable

    a = split_stable(full).stable
    b = split_stable(reduced).stable
    return hinf_norm_stable(
        scipy.linalg.block_diag(a.A, b.A), np.vstack([a.B, b.B]), np.hstack([a.C, -b.C]), a.D - b.D,
    )

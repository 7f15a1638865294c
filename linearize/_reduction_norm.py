"""Measured H-infinity norms of reduction errors ``G - G_r``: the stable parts' difference
(:func:`stable_parts_error`), the second path that checks a measurement against the full system
(:func:`checked_against_full`) and the norm for sparse systems (:func:`sparse_error_norm`).

The norm itself (pole-aware sweep, refinement, Hamiltonian certificate) is
:func:`linflex.frequency._hinf.hinf_norm_stable`, the one H-infinity module of linflex.
Used by the reductions when the caller asks for a measured error (``measure_error=True``).
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
import scipy.linalg
import scipy.sparse

from linflex import AccuracyWarning, LinearSystem, ModelError
from linflex.frequency import HinfNorm, hinf_norm
from linflex.frequency._evaluate import TransferEvaluator
from linflex.frequency._hinf import hinf_norm_stable, pole_grid, refined, top_maxima
from linflex.frequency._modal_forms import block_components

__all__ = ["hinf_norm_stable", "stable_parts_error", "checked_against_full", "sparse_error_norm"]


def sparse_error_norm(full: LinearSystem, reduced: LinearSystem, *, rtol: float = 1e-6) -> HinfNorm:
    """A measured ``||G - G_r||_inf`` of a reduction of a sparse system (``full.A`` sparse).

    When the error system ``(blockdiag(A, A_r), [B; B_r], [C, -C_r], D - D_r)`` is block
    diagonal (a modal model and its reduction) and stable, its norm with an upper bound, by the
    interval method of :func:`linflex.frequency.hinf_norm` on its block-modal form (O(n) per
    point). Otherwise a sweep: ``G`` by the engine's sparse path (one sparse LU per frequency),
    ``G_r`` by its own dense one, on the grid of :func:`pole_grid` over the *reduced* system's
    poles (the sparse system's are not all known), the eight largest local maxima refined; the
    value is attained (a lower bound of the norm) and not certified: a peak of the error between
    grid points, far from every reduced pole, can be missed. ``evaluation_error`` is the two
    evaluations' bound at the peak.
    """
    t0 = time.perf_counter()
    if full.n_inputs == 0 or full.n_outputs == 0:
        return HinfNorm(value=0.0, omega=0.0, certified=True, rtol=rtol, n_evaluations=0,
                        method="no inputs or no outputs: G is empty", seconds=time.perf_counter() - t0, upper=0.0)
    Ae = scipy.sparse.block_diag([full.A_sparse, scipy.sparse.csr_matrix(reduced.A)], format="csr")
    if block_components(Ae) is not None:
        error = LinearSystem(Ae, np.vstack([full.B, reduced.B]), np.hstack([full.C, -reduced.C]),
                             np.asarray(full.D) - np.asarray(reduced.D))
        try:
            res = hinf_norm(error, rtol=rtol, method="interval")
        except ModelError:   # the blocks' modal form is unusable (ill-conditioned blocks): sweep
            res = None
        if res is not None and math.isfinite(res.value):
            return res
    evf, evr = TransferEvaluator(full), TransferEvaluator(reduced)
    count = [0]

    def gain(w: float) -> float:
        count[0] += 1
        return float(np.linalg.svd(evf([w])[0] - evr([w])[0], compute_uv=False)[0])

    w = pole_grid(evr.poles if reduced.n_states else np.zeros(0, complex))
    Gf, Gr = evf(w), evr(w)
    count[0] += w.size
    g = np.linalg.svd(Gf - Gr, compute_uv=False)[:, 0]
    k = int(np.argmax(g))
    best_w, best = refined(gain, w, top_maxima(g), rtol, float(w[k]), float(g[k]))
    Gf_peak = evf([best_w])
    Gr_peak = evr([best_w])
    eval_err = float(evf.last_error[0] * np.abs(Gf_peak).max() + evr.last_error[0] * np.abs(Gr_peak).max())
    return HinfNorm(
        value=best, omega=best_w, certified=False, rtol=rtol, n_evaluations=count[0],
        method="sweep over the reduced poles + local refinement (sparse system: a lower bound, not certified)",
        seconds=time.perf_counter() - t0, evaluation_error=eval_err,
    )


def checked_against_full(full, reduced, measured: HinfNorm, *, n_points: int = 60) -> HinfNorm:
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
    measured : HinfNorm
        The measurement of the stable parts.
    n_points : int
        Frequencies of the check.

    Returns
    -------
    HinfNorm
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

    if full.n_inputs == 0 or full.n_outputs == 0:
        # an empty transfer function: nothing to evaluate, the measurement stands (zero)
        return dataclasses.replace(measured, method=measured.method + " (no inputs or no outputs: G is empty)")
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
    # a value the check raised above the measurement's bound voids that bound
    upper = measured.upper if value <= measured.upper else math.inf
    return dataclasses.replace(measured, value=value, omega=omega, certified=certified, method=method, upper=upper,
                               evaluation_error=max(measured.evaluation_error, worst))


def stable_parts_error(full, reduced) -> HinfNorm:
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

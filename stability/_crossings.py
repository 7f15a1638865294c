"""Crossings of a loop found, not sampled: adaptive grid refinement and root finding in ``log w``.

A crossing (``|L| = 1``, or ``L`` on the negative real axis) that falls exactly on a grid point, at a
resonance, or where ``|L|`` only touches 1 is found and reported once (:func:`crossings`).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.optimize
from numpy.typing import NDArray
from scipy.optimize.elementwise import find_root

from linflex import AccuracyWarning
from linflex.system import frozen_array

__all__ = ["extend", "refine", "crossings", "polish", "MAG_WINDOW"]

#: Grid refinement: an interval is split while the phase of L changes by more than this [deg] ...
_MAX_DPHASE_DEG = 8.0
#: ... or log10 |L| changes by more than this (0.05 = 1 dB).
_MAX_DLOG10 = 0.05
#: |L| outside this window: a crossing there would be a gain margin beyond 200 dB.
MAG_WINDOW = (1e-10, 1e10)

def _scalar(f):
    """``x -> float(f([x])[0])``: a vectorized function of this module's convention at one point."""
    return lambda x: float(np.asarray(f(np.array([x])), dtype=float)[0])


def extend(f_log: callable, w: float, factor: float, limit: int = 24) -> list[float]:
    """Points beyond a grid end while ``log|L|`` (``f_log``, vectorized over ``w`` [rad/s]) still
    moves towards 0 dB (asymptotic region)."""
    f_log = _scalar(f_log)
    out = []
    g0 = f_log(w)
    for _ in range(limit):
        w1 = w * factor
        g1 = f_log(w1)
        if not (np.isfinite(g1) and np.isfinite(g0)) or w1 <= 0 or not np.isfinite(w1):
            break
        if np.sign(g1) != np.sign(g0):
            out.append(w1)
            break
        if abs(g1) < abs(g0) - 1e-3:
            out.append(w1)
            w, g0 = w1, g1
            continue
        break
    return out


def refine(grid: NDArray[np.float64], values: NDArray[np.complex128], ev, max_points: int, depth: int = 14):
    """Insert geometric midpoints where the phase or the magnitude of L changes too fast."""
    for _ in range(depth):
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = values[1:] / values[:-1]
            dphase = np.degrees(np.abs(np.angle(ratio)))
            dlog = np.abs(np.log10(np.abs(ratio)))
            mag = np.abs(values)
        bad = (dphase > _MAX_DPHASE_DEG) | (dlog > _MAX_DLOG10) | ~np.isfinite(ratio)
        bad &= grid[1:] / grid[:-1] > 1 + 1e-12
        # no refinement where |L| stays below 1e-10 or above 1e10: a crossing there would mean a
        # gain margin beyond 200 dB, and the response of the model is only rounding noise
        bad &= ~((mag[1:] < MAG_WINDOW[0]) & (mag[:-1] < MAG_WINDOW[0]))
        bad &= ~((mag[1:] > MAG_WINDOW[1]) & (mag[:-1] > MAG_WINDOW[1]))
        if not bad.any():
            break
        if grid.size + bad.sum() > max_points:
            warnings.warn(
                f"stability_margins: the frequency grid reached max_points={max_points} with "
                f"{int(bad.sum())} intervals still unresolved; crossings inside them may be missed",
                AccuracyWarning, stacklevel=4,
            )
            break
        i = np.flatnonzero(bad)
        mid = np.sqrt(grid[i] * grid[i + 1])
        vm = ev(mid)
        grid = np.insert(grid, i + 1, mid)
        values = np.insert(values, i + 1, vm)
    return grid, values


#: Up to this many brackets :func:`_roots` refines each by Brent's method (scipy's ``brentq``,
#: its loop in C, one single-point evaluation per step); above, all together by Chandrupatla's
#: method, whose Python framework costs about 0.15 ms a step (measured: 7 steps, 1.1 to 2 ms a
#: call, the time of about as many single-point evaluations of a loop of a few states; a
#: 201-state loop with 119 gain crossovers went from 1059 evaluator calls to 91).
BRENT_MAX = 2


def _roots(f, a: NDArray[np.float64], b: NDArray[np.float64], xtol: float) -> NDArray[np.float64]:
    """The root of ``f`` in each bracket ``[a_i, b_i]`` (in log w), to ``xtol * 1e-3 + xtol
    |t|``; ``nan`` where ``f`` does not change sign over the bracket, or is not finite inside it
    (the bracket holds a pole on the axis). Above :data:`BRENT_MAX` brackets, all together: one
    call of ``f`` (vectorized) per step of Chandrupatla's method
    (:func:`scipy.optimize.elementwise.find_root`, Brent's safeguards with inverse quadratic
    steps).

    The sign test on the grid used the scan's evaluations; rounding may differ when the ends are
    evaluated again with other points, when ``f`` is within rounding of zero there, hence the
    check here: an end within a few ulps of 0 is the root, whichever side rounding put it on.
    """
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    xtol = max(xtol, _BRENT_RTOL)  # tighter than rounding: neither method would stop
    out = np.full(a.size, np.nan)
    if a.size == 0:
        return out
    fab = np.asarray(f(np.concatenate([a, b])), dtype=float)
    fa, fb = fab[:a.size], fab[a.size:]
    at_a = np.abs(fa) <= _ROOT_FLOOR
    at_b = ~at_a & (np.abs(fb) <= _ROOT_FLOOR)
    out[at_a], out[at_b] = a[at_a], b[at_b]
    go = ~at_a & ~at_b & np.isfinite(fa) & np.isfinite(fb) & (np.sign(fa) != np.sign(fb))
    if 0 < np.count_nonzero(go) <= BRENT_MAX:
        for i in np.flatnonzero(go):
            try:
                out[i] = scipy.optimize.brentq(_scalar(f), a[i], b[i], xtol=xtol * 1e-3, rtol=xtol)
            except ValueError:  # f is not finite inside (a pole on the axis in the bracket)
                pass
    elif np.any(go):
        with np.errstate(invalid="ignore", divide="ignore"):
            res = find_root(f, (a[go], b[go]),
                            tolerances={"xatol": xtol * 1e-3, "xrtol": xtol, "fatol": 0.0, "frtol": 0.0})
        out[go] = np.where(res.success, res.x, np.nan)
    return out


#: Smallest relative tolerance scipy's ``brentq`` accepts (``4 eps``; below it raises, which
#: read as a bracket without a root, and Chandrupatla's method reported no convergence): a
#: tighter ``crossing_tol`` refines to rounding.
_BRENT_RTOL = 4 * np.finfo(float).eps
#: Roots closer than ten times this (relative, or ``xtol`` when tighter) are one root found twice.
_DUPLICATE_RTOL = 1e-10

#: Values of the dimensionless crossing functions treated as zero (a few ulps).
_ROOT_FLOOR = 64 * np.finfo(float).eps
#: A grid extremum of f within this of zero is examined for a touching or a hidden pair of roots.
_TOUCH_WINDOW = 0.2


def crossings(grid: NDArray[np.float64], fg: NDArray[np.float64], f, xtol: float,
              noise: NDArray[np.float64] | None = None) -> list[float]:
    """Every root of ``f`` (a function of ``t = log w``, vectorized: an array of ``t`` to an array
    of values) found, not sampled, each reported once.

    ``noise`` (optional, per grid point): the a-posteriori bound of the error of ``fg`` there; a
    value within it (or within a few ulps of 0) has no known sign.

    - an isolated grid value within a few ulps of 0 is a root (a crossing on a grid point, say
      |1/s^3| = 1 at w = 1);
    - a sign change between neighbours is refined (:func:`_roots`, every bracket together; between
      the neighbours' neighbours when an end evaluated again changes its sign: a root on a grid
      point);
    - a run of two or more values of unknown sign (``L(jw) = -1/w^10`` is real on the whole axis,
      ``k/s^2`` under a similarity is real to rounding) is a stretch of the curve lying on the
      critical line to working precision, not a set of crossings: one root (refined between the
      run's neighbours) when the signs on its two sides differ, none otherwise;
    - an interior grid extremum of ``f`` within ``_TOUCH_WINDOW`` of zero without a sign change
      (|L| touching 1 at a resonance, or two roots between three grid points) is polished by a
      bounded search; if the extremum reaches zero to ``1e-12`` it is one (tangent) root, if it
      crosses zero the two roots on either side are refined.
    """
    t = np.log(grid)
    xtol = max(xtol, _BRENT_RTOL)
    finite = np.isfinite(fg)
    floor = _ROOT_FLOOR if noise is None else np.maximum(_ROOT_FLOOR, np.where(np.isfinite(noise), noise, np.inf))
    unknown = finite & (np.abs(fg) <= floor)
    s = np.where(unknown, 0.0, np.sign(fg))
    zero = finite & (np.abs(fg) <= _ROOT_FLOOR)
    roots = []
    # runs of values of unknown sign (a single exact zero is a root on a grid point); their
    # brackets and the sign changes between neighbours are solved together
    lo_t, hi_t = [], []
    edges = np.flatnonzero(np.diff(np.r_[0, unknown.astype(int), 0]))
    for lo, hi in zip(edges[::2], edges[1::2]):
        if hi - lo == 1 and zero[lo]:
            roots.append(float(grid[lo]))
            continue
        if lo > 0 and hi < fg.size and finite[lo - 1] and finite[hi] and s[lo - 1] * s[hi] < 0:
            lo_t.append(t[lo - 1])
            hi_t.append(t[hi])
    n_runs = len(lo_t)
    changes = np.flatnonzero(finite[:-1] & finite[1:] & (s[:-1] * s[1:] < 0))
    x = _roots(f, np.r_[lo_t, t[changes]], np.r_[hi_t, t[changes + 1]], xtol)
    # an end within the evaluation's error of 0 (a crossing on a grid point, beside an undamped
    # pole: log|L| = 1e-11 in the scan, -1e-11 evaluated alone) may change sign when evaluated
    # again: the bracket of its neighbours on both sides then holds the root
    wider = []
    for k, i in enumerate(changes):
        lo, hi = max(i - 1, 0), min(i + 2, fg.size - 1)
        if np.isnan(x[n_runs + k]) and (lo, hi) != (i, i + 1) and finite[lo:hi + 1].all() and s[lo] * s[hi] < 0:
            wider.append((lo, hi))
    found = x[~np.isnan(x)]
    if wider:
        lo, hi = np.array(wider).T
        again = _roots(f, t[lo], t[hi], xtol)
        found = np.r_[found, again[~np.isnan(again)]]
    roots.extend(np.exp(found).tolist())
    if fg.size >= 3:
        f0, f1, f2 = fg[:-2], fg[1:-1], fg[2:]
        with np.errstate(invalid="ignore"):
            ext = (finite[:-2] & finite[1:-1] & finite[2:] & (s[:-2] == s[1:-1]) & (s[1:-1] == s[2:]) & (s[1:-1] != 0)
                   & (np.abs(f1) <= np.minimum(np.abs(f0), np.abs(f2))) & (np.abs(f1) < _TOUCH_WINDOW))
        f1d = _scalar(f)
        pairs = []
        for j in np.flatnonzero(ext) + 1:
            sg = s[j]
            res = scipy.optimize.minimize_scalar(lambda x, sg=sg: sg * f1d(x), bounds=(t[j - 1], t[j + 1]),
                                                 method="bounded", options={"xatol": xtol * 1e-3})
            v = sg * float(res.fun)
            if not np.isfinite(v):
                continue
            if abs(v) <= 1e-12:
                roots.append(float(np.exp(res.x)))
            elif np.sign(v) != sg:
                pairs += [(t[j - 1], res.x), (res.x, t[j + 1])]
        if pairs:
            lo, hi = np.array(pairs).T
            x = _roots(f, lo, hi, xtol)
            roots.extend(np.exp(x[~np.isnan(x)]).tolist())
    if not roots:
        return []
    roots = np.sort(np.array(roots))
    # one root found twice (the same point, or one touching found from two equal extrema); roots
    # of different brackets are distinct however close, so a loose xtol does not merge them
    keep = np.r_[True, np.diff(roots) > 10 * min(xtol, _DUPLICATE_RTOL) * roots[1:]]
    return roots[keep].tolist()


def polish(f, w: float, xtol: float) -> float:
    """The root ``w`` [rad/s] of ``f`` (of ``t = log w``, vectorized), found to ``xtol`` by
    :func:`crossings`, refined to rounding; ``nan`` when ``f`` does not change sign within twice
    that tolerance of it, or is not finite there.

    A root to a loose ``crossing_tol`` leaves ``f`` at about its slope times the tolerance: beside
    a mode of damping 1e-3 at 1000 rad/s, ``Im L / |L|`` is 1.1e-6 at a phase crossover found to
    1e-9 and 4e-4 at one found to 1e-6, which a test of ``|Im L| / |L| <= 1e-6`` takes for a
    sign change through a pole.
    """
    t = float(np.log(w))
    d = 2.0 * (xtol * 1e-3 + xtol * abs(t)) + 8 * _BRENT_RTOL * max(abs(t), 1.0)
    return float(np.exp(_roots(f, np.array([t - d]), np.array([t + d]), _BRENT_RTOL)[0]))


def crossing_summary(wgc, pm, dm, wpc, gm) -> dict:
    """The LoopMargins fields derived from the crossings: read-only arrays, the smallest phase margin
    (by |PM|) and gain margin (by |log GM|) with their frequencies, the delay margin, and the gain
    increase and reduction margins. Frequencies [rad/s], phase margins [deg], delays [s]."""
    wgc, pm, dm, wpc, gm = (frozen_array(a) for a in (wgc, pm, dm, wpc, gm))
    j = int(np.argmin(np.abs(pm))) if wgc.size else None
    with np.errstate(divide="ignore"):
        k = int(np.argmin(np.abs(np.log(gm)))) if wpc.size else None
    up, down = gm[gm > 1], gm[gm < 1]
    return dict(
        gain_crossovers=wgc, phase_margins=pm, delay_margins=dm, phase_crossovers=wpc, gain_margins=gm,
        delay_margin=float(dm.min()) if dm.size else np.inf,
        min_phase_margin=float(pm[j]) if j is not None else np.inf,
        min_phase_margin_frequency=float(wgc[j]) if j is not None else np.nan,
        min_gain_margin=float(gm[k]) if k is not None else np.inf,
        min_gain_margin_frequency=float(wpc[k]) if k is not None else np.nan,
        gain_increase_margin=float(up.min()) if up.size else np.inf,
        gain_reduction_margin=float(down.max()) if down.size else 0.0,
    )

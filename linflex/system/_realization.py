"""Realizations of transfer functions: the controllable canonical form of one ``num / den``
(exact in its coefficients), and the a-posteriori check of a realization python-control made of
a MIMO transfer function against its polynomials."""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

from ._errors import AccuracyWarning, ModelError, ShapeError

__all__ = ["check_realization", "siso_realization"]


def siso_realization(num: NDArray, den: NDArray, name: str):
    """``(A, B, C, D)``: the controllable canonical form of ``num / den`` (``scipy.signal.tf2ss``;
    no states for a static gain), with the coefficients checked."""
    import scipy.signal

    for label, coefficients in (("num", num), ("den", den)):
        if coefficients.ndim != 1:
            raise ShapeError(f"{name}: {label} must be a 1-D coefficient vector, got shape {coefficients.shape}")
        if not np.all(np.isfinite(coefficients)):
            raise ShapeError(f"{name}: {label} has non-finite coefficients {coefficients.tolist()}")
    if not np.any(den):
        raise ModelError(f"{name}: den must have a non-zero coefficient, got {den.tolist()}")
    num, den = np.trim_zeros(num, "f"), np.trim_zeros(den, "f")
    if num.size > den.size:
        raise ModelError(
            f"{name}: improper transfer function (numerator degree {num.size - 1} > denominator degree "
            f"{den.size - 1}); a state-space system needs len(num) <= len(den)"
        )
    if den.size == 1:  # a static gain has no states (scipy.signal.tf2ss would give it one)
        gain = num[-1] / den[0] if num.size else 0.0
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[gain]])
    return scipy.signal.tf2ss(num if num.size else [0.0], den)


# Points per decade and decades either side of the roots' scale at which a MIMO transfer
# function's realization is compared with its polynomials (check_realization).
_CHECK_PER_DECADE, _CHECK_DECADES = 4, 4
# A realization within this relative distance of the polynomials (beyond their own rounding)
# passes in silence.
_CHECK_RTOL = 1e-10


def check_realization(tf, ss, name: str) -> float:
    """The largest normwise relative difference (largest entry over largest entry, beyond the
    polynomials' rounding) between a MIMO transfer function's polynomials and the realization
    python-control made of it (SLICOT TD04AD's staircase, exact only to eps of its
    norm), over the frequencies about its poles and zeros; an ``AccuracyWarning`` where it
    exceeds ``_CHECK_RTOL`` plus the polynomials' own rounding bound. Returns that difference [-]."""
    num = [[np.asarray(c, float) for c in row] for row in tf.num]
    den = [[np.asarray(c, float) for c in row] for row in tf.den]
    roots = np.concatenate([np.roots(c) for rows in (num, den) for row in rows for c in row if c.size > 1] or [[]])
    size = np.abs(roots[np.isfinite(roots)])
    size = size[size > 0]
    scale = float(np.exp(np.mean(np.log(size)))) if size.size else 1.0
    if ss.isdtime():
        points = np.exp(1j * np.linspace(1e-3, np.pi, 8 * _CHECK_PER_DECADE))
    else:
        lo, hi = np.log10(size.min(initial=scale)), np.log10(size.max(initial=scale))
        points = 1j * np.logspace(lo - _CHECK_DECADES, hi + _CHECK_DECADES,
                                  int((hi - lo + 2 * _CHECK_DECADES) * _CHECK_PER_DECADE) + 1)
    eps = np.finfo(float).eps
    worst, at = 0.0, None
    A, B, C, D = (np.asarray(m, float) for m in (ss.A, ss.B, ss.C, ss.D))
    for s_ in points:
        try:
            G = C @ np.linalg.solve(s_ * np.eye(A.shape[0]) - A, B) + D
        except np.linalg.LinAlgError:
            continue  # a pole on the sample: its neighbours tell
        dens = np.array([[np.polyval(d, s_) for d in row] for row in den])
        if np.any(dens == 0):
            continue  # a pole of an entry on the sample: its neighbours tell
        g = np.array([[np.polyval(n, s_) for n in row] for row in num]) / dens
        # Horner's rounding bound of each polynomial (Higham, eq. 5.3), as an error of g
        bound = np.array([[2 * (n.size + d.size) * eps * (np.polyval(np.abs(n), abs(s_))
                                                          + abs(gij) * np.polyval(np.abs(d), abs(s_)))
                           for n, d, gij in zip(nrow, drow, grow)]
                          for nrow, drow, grow in zip(num, den, g)]) / np.abs(dens)
        peak = float(np.max(np.abs(g)))
        excess = float(np.max(np.abs(G - g) - bound)) / peak if peak > 0 else 0.0
        if excess > worst:
            worst, at = excess, s_
    if worst > _CHECK_RTOL:
        where = f"|z| = 1, angle {np.angle(at):.3g} rad" if ss.isdtime() else f"{abs(at):.3g} rad/s"
        warnings.warn(f"{name}: python-control's realization of this MIMO transfer function (control.ss) differs "
                      f"from its polynomials by {worst:.2g} (relative) at {where}; every result on it carries that "
                      "error. Give the system in state space for exact results.", AccuracyWarning, stacklevel=4)
    return worst

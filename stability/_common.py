"""Helpers shared by the stability modules: scales and tolerances."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = ["rigid_mask", "system_scale", "check_positive"]

#: Largest |lambda| / scale of a rigid-body eigenvalue: a Jordan block of size k at the origin is
#: split by rounding into k eigenvalues of size (eps * scale^k)^(1/k) ~ eps^(1/k) * scale, which is
#: 1.2e-4 * scale for k = 4 (a quadruple integrator).
RIGID_CLUSTER_RTOL = 1e-3
#: Largest |sum of the group's eigenvalues| / (scale * eps): the trace of the block is well
#: conditioned even when the eigenvalues of a Jordan block are not.
RIGID_TRACE_FACTOR = 1e3
#: Smallest ratio between the modulus of the first eigenvalue outside the rigid group and the
#: largest inside it.
RIGID_GAP = 10.0


def system_scale(A: NDArray[np.float64]) -> float:
    """1-norm of the balanced ``A`` [1/s], or of ``A`` if smaller (1.0 for a zero matrix)."""
    if A.shape[0] == 0:
        return 1.0
    balanced, _ = scipy.linalg.matrix_balance(A, permute=False)
    scale = float(min(np.linalg.norm(balanced, 1), np.linalg.norm(A, 1)))
    return scale if scale > 0 else 1.0


def rigid_mask(eigs: NDArray[np.complex128], A: NDArray[np.float64], rigid_tol: float | None):
    """Which eigenvalues are rigid-body (zero) eigenvalues, and the radius used [1/s].

    With ``rigid_tol`` given: ``|lambda| <= rigid_tol``. Otherwise the rigid group is the largest
    set of the smallest eigenvalues (by modulus, up to ``1e-3 * scale``) whose sum is zero to
    rounding (``|sum| <= 1e3 * eps * scale``), taken cluster by cluster (clusters separated by a
    factor of 10 in modulus), a cluster of k eigenvalues being no wider than
    ``100 eps^(1/k) scale``: the eigenvalues of a Jordan block at the origin
    computed in floating point scatter on a circle of radius ``eps^(1/k) * scale`` around 0 but
    keep a zero sum, while a genuine slow pole (say -1e-4 beside modes at 100 rad/s) does not.
    Eigenvalues placed symmetrically about the origin and tiny relative to ``scale`` are
    indistinguishable from a perturbed Jordan block and are labelled rigid.
    """
    eigs = np.asarray(eigs, dtype=complex)
    mask = np.zeros(eigs.shape, dtype=bool)
    if eigs.size == 0:
        return mask, 0.0 if rigid_tol is None else float(rigid_tol)
    if rigid_tol is not None:
        tol = check_positive(rigid_tol, "rigid_tol", allow_zero=True)
        return np.abs(eigs) <= tol, tol
    scale = system_scale(A)
    eps = np.finfo(float).eps
    order = np.argsort(np.abs(eigs), kind="stable")
    mods = np.abs(eigs[order])
    n_small = int(np.count_nonzero(mods <= RIGID_CLUSTER_RTOL * scale))
    # clusters of the small eigenvalues, separated by gaps of RIGID_GAP in modulus
    bounds = [0] + [j for j in range(1, n_small + 1)
                    if j == n_small or mods[j] > RIGID_GAP * mods[j - 1]]
    best, total = 0, 0j
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if hi <= lo:
            continue
        k = hi - lo
        total += eigs[order[lo:hi]].sum()
        # a Jordan block of size k at the origin scatters into k eigenvalues of modulus about
        # eps^(1/k) * scale with a vanishing sum; an undamped slow pair also sums to zero but is
        # far larger than eps^(1/2) * scale
        radius_ok = mods[hi - 1] <= 100 * eps ** (1.0 / k) * scale
        gap_ok = hi == mods.size or mods[hi] >= RIGID_GAP * mods[hi - 1]
        if abs(total) <= RIGID_TRACE_FACTOR * eps * scale and radius_ok and gap_ok:
            best = hi
        else:
            break
    small = list(order)
    rigid = small[:best]
    mask[rigid] = True
    radius = float(np.abs(eigs[rigid]).max()) if rigid else 0.0
    return mask, radius


def check_positive(value, name: str, *, allow_zero: bool = False) -> float:
    """A finite positive float (or non-negative with ``allow_zero``), else a ``ValueError``."""
    from linflex import ModelError

    try:
        v = float(value)
    except (TypeError, ValueError) as err:
        raise ModelError(f"{name} must be a real number, got {value!r}") from err
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        expected = "non-negative" if allow_zero else "positive"
        raise ModelError(f"{name} must be a finite {expected} number, got {value!r}")
    return v

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
    rounding (``|sum| <= 1e3 * eps * scale``): the eigenvalues of a Jordan block at the origin
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
    order = np.argsort(np.abs(eigs), kind="stable")
    small = [i for i in order if abs(eigs[i]) <= RIGID_CLUSTER_RTOL * scale]
    best = 0
    total = 0j
    for j, i in enumerate(small, start=1):
        total += eigs[i]
        if abs(total) <= RIGID_TRACE_FACTOR * np.finfo(float).eps * scale:
            best = j
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

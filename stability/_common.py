"""Helpers shared by the stability modules: scales and tolerances."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = ["rigid_tolerance", "check_positive"]

#: Relative tolerance below which an eigenvalue counts as a rigid-body (zero) eigenvalue.
RIGID_RTOL = 1e-6


def rigid_tolerance(A: NDArray[np.float64], rigid_tol: float | None) -> float:
    """Absolute tolerance [1/s] on ``|lambda|`` for rigid-body eigenvalues.

    The default is ``1e-6`` times the 1-norm of the balanced ``A`` (``scipy.linalg.matrix_balance``),
    so that the test does not depend on the units of the states. A Jordan block of size 2 at the
    origin (a double integrator) is split by rounding into eigenvalues of size
    ``sqrt(eps * ||A||)``, far below this tolerance for any ``||A||`` up to 1e12.
    """
    if rigid_tol is not None:
        return check_positive(rigid_tol, "rigid_tol", allow_zero=True)
    if A.shape[0] == 0:
        return 0.0
    balanced, _ = scipy.linalg.matrix_balance(A, permute=False)
    scale = float(np.linalg.norm(balanced, 1))
    return RIGID_RTOL * scale if scale > 0 else RIGID_RTOL


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

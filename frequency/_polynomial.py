"""Small polynomial controller blocks to state space (reference notes, section 9)."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from linflex import LinearSystem, ModelError, ShapeError

__all__ = ["realize_polynomial"]

_MAX_ORDER = 10


def _coefficients(value, name: str) -> np.ndarray:
    try:
        raw = np.asarray(value)
        c = None if np.iscomplexobj(raw) else np.array(raw, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"{name} must be a sequence of real coefficients, highest power first: {err}") from err
    if c is None:  # a cast would drop the imaginary parts
        raise ShapeError(f"{name} must hold real coefficients, got complex values")
    if c.ndim == 0:
        c = c.reshape(1)
    if c.ndim != 1 or c.size == 0:
        raise ShapeError(f"{name} must be a non-empty 1-D sequence of coefficients, got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ShapeError(f"{name}[{int(np.argmax(~np.isfinite(c)))}] is not finite")
    nz = np.flatnonzero(c)
    return c[nz[0]:] if nz.size else np.zeros(1)


def realize_polynomial(num: ArrayLike, den: ArrayLike, *, input: str = "u", output: str = "y") -> LinearSystem:
    """State-space realization of a small SISO block ``P(s)/Q(s)`` (controllers, filters).

    Parameters
    ----------
    num, den : array_like
        Coefficients of ``P`` and ``Q``, highest power first (leading zeros are dropped);
        ``deg P <= deg Q <= 10``.
    input, output : str, optional
        Signal names.

    Returns
    -------
    LinearSystem
        The observer canonical form of the DISCOS report (III-64 ff.), then balanced by a
        diagonal similarity (LAPACK ``gebal``), which leaves the transfer function unchanged and
        evens out the scales of the companion-form states.

    Raises
    ------
    ShapeError
        If ``num`` or ``den`` is not a non-empty 1-D sequence of real finite coefficients.
    ModelError
        If ``Q`` is zero, the block is improper (``deg P > deg Q``) or of order above 10:
        polynomial forms are ill-conditioned beyond that; give large models in state space.

    Notes
    -----
    With ``c_i = a_i/a_n`` and ``d_i = b_i/a_n``::

        A = [-c_{n-1} 1      ]   B = [d_{n-1} - c_{n-1} d_n]   C = [1 0 ... 0]   D = d_n
            [-c_{n-2}   1    ]       [d_{n-2} - c_{n-2} d_n]
            [  ...        1  ]       [        ...          ]
            [-c_0     0 ... 0]       [d_0     - c_0 d_n    ]

    Examples
    --------
    >>> K = realize_polynomial([3.0, 1.0], [0.02, 1.0])          # (3 s + 1) / (0.02 s + 1)
    >>> K.A.tolist(), round(float(K.D[0, 0]), 9)
    ([[-50.0]], 150.0)
    """
    b = _coefficients(num, "num")
    a = _coefficients(den, "den")
    if not np.any(a):
        raise ModelError("den is the zero polynomial")
    n = len(a) - 1
    if len(b) - 1 > n:
        raise ModelError(f"the block is improper: deg num = {len(b) - 1} > deg den = {n}")
    if n > _MAX_ORDER:
        raise ModelError(
            f"den has degree {n}; polynomial blocks are limited to order {_MAX_ORDER} (coefficients of higher "
            "order are ill-conditioned): give the block in state-space form"
        )
    c = a / a[0]
    d = np.zeros(n + 1)
    d[n + 1 - len(b):] = b / a[0]
    if n == 0:
        return LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[d[0]]], inputs=[input],
                            outputs=[output])
    # coefficients highest power first: c[0] = 1, c[k] multiplies s^(n-k)
    A = np.zeros((n, n))
    A[:, 0] = -c[1:]
    A[:-1, 1:] = np.eye(n - 1)
    B = (d[1:] - c[1:] * d[0]).reshape(n, 1)
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    _, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    A = A * (1.0 / scale)[:, None] * scale[None, :]
    B = B / scale[:, None]
    C = C * scale[None, :]
    return LinearSystem(A, B, C, [[d[0]]], inputs=[input], outputs=[output])

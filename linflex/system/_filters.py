"""Structural filters of an attitude controller: notch, second-order low-pass, lead-lag.

Each is a single-input single-output :class:`LinearSystem` in continuous time, in the
controllable canonical form of its transfer function, with input ``"in"`` and output ``"out"``.
The scene's controller chains and :mod:`linflex.design` build their filters here (one definition
of each filter). Frequencies are in rad/s.
"""

from __future__ import annotations

import numpy as np

from ._errors import ModelError
from ._linear import LinearSystem
from ._signals import check_positive

__all__ = ["notch", "low_pass", "lead_lag"]


def _second_order(num: tuple[float, float, float], den: tuple[float, float, float]) -> LinearSystem:
    """``(n2 s^2 + n1 s + n0) / (s^2 + d1 s + d0)`` in controllable canonical form."""
    n2, n1, n0 = num
    _, d1, d0 = den
    A = [[0.0, 1.0], [-d0, -d1]]
    C = [[n0 - n2 * d0, n1 - n2 * d1]]
    return LinearSystem(A, [[0.0], [1.0]], C, [[n2]], inputs=["in"], outputs=["out"], states=["x1", "x2"])


def notch(frequency: float, depth: float, width: float) -> LinearSystem:
    """A notch filter ``(s^2 + 2 zn w s + w^2) / (s^2 + 2 zd w s + w^2)``.

    Parameters
    ----------
    frequency : float
        Centre frequency ``w`` [rad/s], where the gain is smallest.
    depth : float
        Attenuation at the centre [dB], positive: the gain there is ``10^(-depth/20) = zn / zd``.
    width : float
        Width of the notch [rad/s]: ``2 zd w``, the distance between the frequencies where the
        denominator's pole pair is 3 dB down (for a deep notch, where the attenuation is about
        3 dB). The pole damping ``zd = width / (2 w)`` must not exceed 1.

    Returns
    -------
    LinearSystem
        Unit gain at 0 and at infinity (``D = 1``), ``depth`` dB down at ``frequency``.

    Raises
    ------
    ModelError
        For a non-positive frequency, depth or width, or a width above ``2 frequency``.

    Examples
    --------
    A 20 dB notch at 10 rad/s, 4 rad/s wide: gain 0.1 at 10 rad/s.

    >>> import numpy as np
    >>> f = notch(10.0, 20.0, 4.0)
    >>> s = 10j
    >>> g = (f.C @ np.linalg.solve(s * np.eye(2) - f.A, f.B) + f.D)[0, 0]
    >>> round(float(abs(g)), 12)
    0.1
    """
    w = check_positive(frequency, "frequency")
    depth_db = check_positive(depth, "depth")
    zd = check_positive(width, "width") / (2.0 * w)
    if zd > 1.0:
        raise ModelError(f"width = {width} rad/s is more than twice the frequency {w} rad/s (pole damping {zd:.3g} > 1)")
    zn = zd * 10.0 ** (-depth_db / 20.0)
    return _second_order((1.0, 2.0 * zn * w, w * w), (1.0, 2.0 * zd * w, w * w))


def low_pass(frequency: float, damping: float = 0.7) -> LinearSystem:
    """A second-order low-pass filter ``w^2 / (s^2 + 2 z w s + w^2)``.

    Parameters
    ----------
    frequency : float
        Natural frequency ``w`` [rad/s]; above it the gain falls by 40 dB per decade.
    damping : float, optional
        Damping ratio ``z`` of the pole pair [-], 0.7 by default (no peak).

    Returns
    -------
    LinearSystem
        Unit DC gain; gain ``1 / (2 z)`` at ``frequency``.

    Raises
    ------
    ModelError
        For a non-positive frequency or damping.

    Examples
    --------
    >>> f = low_pass(20.0, 0.5)
    >>> f.A.tolist()
    [[0.0, 1.0], [-400.0, -20.0]]
    """
    w = check_positive(frequency, "frequency")
    z = check_positive(damping, "damping")
    return _second_order((0.0, 0.0, w * w), (1.0, 2.0 * z * w, w * w))


def lead_lag(zero: float, pole: float, gain: float = 1.0) -> LinearSystem:
    """A lead (``zero < pole``) or lag (``zero > pole``) filter ``gain (s / zero + 1) / (s / pole + 1)``.

    Parameters
    ----------
    zero, pole : float
        Corner frequencies [rad/s] of the numerator and the denominator.
    gain : float, optional
        DC gain (dimensionless, in the units of the signal it multiplies), 1 by default.

    Returns
    -------
    LinearSystem
        One state; the largest phase lead (or lag) is at ``sqrt(zero pole)`` rad/s, of
        ``arcsin((pole - zero) / (pole + zero))``.

    Raises
    ------
    ModelError
        For a non-positive corner frequency or a non-finite gain.

    Examples
    --------
    >>> f = lead_lag(1.0, 10.0)
    >>> f.A.tolist(), f.D.tolist()
    ([[-10.0]], [[10.0]])
    """
    a = check_positive(zero, "zero")
    b = check_positive(pole, "pole")
    try:
        k = float(gain)
    except (TypeError, ValueError):
        raise ModelError(f"gain must be a finite number, got {gain!r}") from None
    if not np.isfinite(k):
        raise ModelError(f"gain must be a finite number, got {gain!r}")
    # k (s/a + 1)/(s/b + 1) = k b/a (s + a)/(s + b) = k b/a + k b/a (a - b)/(s + b)
    high = k * b / a
    return LinearSystem([[-b]], [[1.0]], [[high * (a - b)]], [[high]], inputs=["in"], outputs=["out"], states=["x1"])
